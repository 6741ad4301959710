"""What a controller sees of the plant at one instant."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np


@dataclasses.dataclass(frozen=True, eq=False)
class PlantState:
    """A snapshot of the plant, given to ``controller(t, state)``; arrays are read-only copies.

    Attributes:
        t: time, s.
        q: joint positions, rad or m, shape (n,).
        qd: joint velocities, rad/s or m/s, shape (n,).
        dP: differential pressures ΔP, Pa, shape (n,) (NaN at joints without a cylinder).
        Q: valve flows, m³/s, shape (n,) (NaN likewise).
        mode: friction/limit modes (``FrictionMode`` values), int array (n,).
        states: every actuator and friction state by name (``dP``, ``Q``, ``z``, plugin states),
            each shape (n,) with NaN at joints without it.
        joint_names: the joints, in order.
    """

    t: float
    q: np.ndarray
    qd: np.ndarray
    dP: np.ndarray
    Q: np.ndarray
    mode: np.ndarray
    states: Mapping[str, np.ndarray]
    joint_names: tuple[str, ...]

    def __post_init__(self) -> None:
        for value in (self.q, self.qd, self.dP, self.Q, self.mode, *self.states.values()):
            value.setflags(write=False)

    def __getitem__(self, name: str) -> np.ndarray:
        """A field or state by name: ``state["q"]``, ``state["z"]``."""
        if name in ("q", "qd", "dP", "Q", "mode"):
            return getattr(self, name)
        try:
            return self.states[name]
        except KeyError:
            raise KeyError(
                f"no state {name!r}; expected q, qd, dP, Q, mode or one of {', '.join(self.states)}"
            ) from None

    def get(self, name: str, default: object = None) -> object:
        """Like ``state[name]``, with a default for unknown names."""
        try:
            return self[name]
        except KeyError:
            return default

    def joint(self, name: str) -> dict[str, float]:
        """All values of one joint by name, e.g. ``{"q": 0.1, "qd": 0.0, "dP": 2e6, ...}``."""
        i = self.joint_names.index(name)
        values = {"q": self.q[i], "qd": self.qd[i], "mode": int(self.mode[i])}
        values.update({k: v[i] for k, v in self.states.items() if not np.isnan(v[i])})
        return {k: (float(v) if k != "mode" else v) for k, v in values.items()}
