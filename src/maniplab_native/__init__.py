"""maniplab's MuJoCo engine plugins: the hydraulic cylinder and LuGre friction, in C.

Registered with MuJoCo through the ``mujoco.plugins`` entry point, so that every MuJoCo tool in
this environment (``python -m mujoco.viewer``, MuJoCo Studio, ``mujoco.rollout``, plain
``mujoco.MjModel.from_xml_path``) simulates an MJCF file exported by maniplab: ``import mujoco``
calls :func:`load`, which builds the library on first use against the installed mujoco's headers
into maniplab's cache and loads it.

This package imports only the standard library (it runs while ``mujoco`` is being imported).
"""

from __future__ import annotations

from maniplab_native.build import PLUGINS, NativeBuildError, library, library_path, load

__all__ = ["PLUGINS", "NativeBuildError", "library", "library_path", "load"]
