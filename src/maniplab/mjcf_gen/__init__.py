"""MJCF generation: spec -> mujoco.MjSpec -> MJCF text (full precision) and mujoco.MjModel.

Public functions:

- :func:`build_mjspec` builds the model with MuJoCo's MjSpec API (the one place it is constructed);
- :func:`build_model` compiles it and checks that every joint moves mass;
- :func:`to_mjcf` / :func:`write_mjcf` give it as MJCF text at full float precision, which plain
  MuJoCo loads into the same model.

Element names (:mod:`maniplab.mjcf_gen.names`): joint and actuator ``<joint>``, body
``link_<joint>`` (frame j after the joint's motion), fixed body and site ``end_effector``.
"""

from __future__ import annotations

from maniplab.mjcf_gen.builder import build_mjspec, build_model
from maniplab.mjcf_gen.names import END_EFFECTOR, body_name
from maniplab.mjcf_gen.writer import to_mjcf, write_mjcf

__all__ = ["END_EFFECTOR", "body_name", "build_mjspec", "build_model", "to_mjcf", "write_mjcf"]
