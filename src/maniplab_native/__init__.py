"""maniplab's native code: its MuJoCo engine plugins and its plant, in C.

One shared library, built on first use against the installed mujoco's headers into maniplab's
cache (:mod:`maniplab_native.build`), holds:

- the engine plugins ``maniplab.hydraulic`` (the valve-controlled cylinder, ``hydraulic.c`` with
  the valve law of ``valve.c``) and ``maniplab.lugre`` (LuGre friction, ``lugre.c``), registered
  with MuJoCo through the ``mujoco.plugins`` entry point, so that every MuJoCo tool in this
  environment (``python -m mujoco.viewer``, MuJoCo Studio, ``mujoco.rollout``, plain
  ``mujoco.MjModel.from_xml_path``) simulates an MJCF file exported by maniplab: ``import mujoco``
  calls :func:`load`;
- the plant (``plant.c``: the friction/limit automaton around MuJoCo's step and the run loop,
  bound in :mod:`maniplab.sim.native`) and the cascade controller's sample (``cascade.c``),
  which maniplab calls through ctypes (:func:`library`).

This package imports only the standard library (it runs while ``mujoco`` is being imported).
"""

from __future__ import annotations

from maniplab_native.build import PLUGINS, NativeBuildError, library, library_path, load

__all__ = ["PLUGINS", "NativeBuildError", "library", "library_path", "load"]
