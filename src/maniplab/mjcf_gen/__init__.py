"""MJCF generation: spec -> mujoco.MjSpec -> MJCF text (full precision) and mujoco.MjModel."""

from __future__ import annotations


def to_mjcf(spec):  # placeholder until the builder lands
    raise NotImplementedError


def build_model(spec):  # placeholder until the builder lands
    raise NotImplementedError
