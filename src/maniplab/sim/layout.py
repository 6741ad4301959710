"""The plant's state layout: where each named actuator or friction state lives in ``d.act``.

Every actuator state (``dP`` and ``Q`` of a cylinder, a plugin's states) and LuGre's bristle
state ``z`` is a MuJoCo activation, so ``mj_getState``, resets and keyframes include them. A name
may be shared by several joints (every cylinder has a ``dP``); a joint without that state has NaN
in the arrays this layout reads.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import mujoco
import numpy as np

from maniplab.actuators import ActuatorPlugin
from maniplab.mjcf_gen.names import LUGRE_SUFFIX

LUGRE_STATE = "z"
"""The name of LuGre's bristle state."""


class StateLayout:
    """Named states: name -> (joint indices, activation addresses), each an int array.

    Args:
        model: the plant's model (actuator i < n drives joint i).
        actuators: the arm's actuator models, one per joint.
        lugre_joints: the names of the joints with LuGre friction (each has ``<joint>/lugre``).
    """

    def __init__(self, model: mujoco.MjModel, actuators: Sequence[ActuatorPlugin],
                 lugre_joints: Sequence[tuple[int, str]]) -> None:
        self.n = len(actuators)
        layout: dict[str, tuple[list[int], list[int]]] = {}
        for i, act in enumerate(actuators):
            adr = int(model.actuator_actadr[i])
            for k, name in enumerate(act.states):
                joints, adrs = layout.setdefault(name, ([], []))
                joints.append(i)
                adrs.append(adr + k)
        for j, name in lugre_joints:
            joints, adrs = layout.setdefault(LUGRE_STATE, ([], []))
            joints.append(j)
            adrs.append(int(model.actuator_actadr[model.actuator(name + LUGRE_SUFFIX).id]))
        self._layout = {k: (np.array(j, dtype=int), np.array(a, dtype=int))
                        for k, (j, a) in layout.items()}
        self.names = tuple(self._layout)

    def __contains__(self, name: object) -> bool:
        return name in self._layout

    def __getitem__(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        return self._layout[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._layout)

    def items(self) -> Iterator[tuple[str, tuple[np.ndarray, np.ndarray]]]:
        """(name, (joint indices, activation addresses)) pairs."""
        return iter(self._layout.items())

    def read(self, act: np.ndarray) -> dict[str, np.ndarray]:
        """Every named state from activations ``act`` (na,) or samples (N, na): arrays (n,) or
        (N, n), NaN at joints without the state."""
        out = {}
        for name, (joints, adrs) in self._layout.items():
            full = np.full((*act.shape[:-1], self.n), np.nan)
            full[..., joints] = act[..., adrs]
            out[name] = full
        return out

