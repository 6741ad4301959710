"""The energy of a run: where each pinned cylinder's hydraulic power went.

Each pinned cylinder's engine plugin (``maniplab_native/cylinder.c``) accumulates, within its own
step, the energy the supply delivered through its valve section and where it went: the losses
across the meter-in orifice, its pressure compensator, the meter-out orifice, the piston's
leakage, the relief and anti-cavitation valves; the energy the return oil carries into the tank
line; the work on the piston; the energy stored by compressing the oil. Every term is taken at
the same instants of the chambers' integration, so that

    pump = meter_in + compensator + meter_out + leakage + relief + anticavitation + tank + work
           + compression

holds to round-off, as the chambers' continuity multiplied by their pressures does at each instant.
The recorder reads the accumulators from the recorded plugin states and gives them as the run's
signals ``E_<term>`` (J, since the run's start, NaN at joints without a pinned cylinder).
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from maniplab.clib import Functions

if TYPE_CHECKING:
    import mujoco

TERMS = ("pump", "meter_in", "compensator", "meter_out", "leakage", "relief", "anticavitation",
         "tank", "work", "compression")
"""The energy terms, in the order of the C accumulators (``chambers.h``, ``ML_E_*``)."""

LOSSES = ("meter_in", "compensator", "meter_out", "leakage", "relief", "anticavitation")
"""The terms that are losses (heat in the oil)."""

SIGNALS = tuple(f"E_{term}" for term in TERMS)
"""The run's energy signals, J."""

DESCRIPTIONS = {
    "pump": "delivered by the supply through the valve section",
    "meter_in": "lost across the meter-in orifice (P to the fed chamber)",
    "compensator": "lost across the section's pressure compensator",
    "meter_out": "lost across the meter-out orifice (the drained chamber to T)",
    "leakage": "lost in the leakage across the piston",
    "relief": "lost through the chambers' relief valves",
    "anticavitation": "lost through the anti-cavitation valves (oil drawn from the tank)",
    "tank": "carried into the tank line by the return oil (Pt Q)",
    "work": "work done on the piston (negative where the load drives it)",
    "compression": "stored by compressing the oil in the chambers and hoses",
}

_C = Functions({"ml_cylinder_energy_slot": (ctypes.c_int, [ctypes.POINTER(ctypes.c_int)])})


def _slot() -> int:
    """Where a cylinder's energies start in its plugin state."""
    count = ctypes.c_int()
    slot = int(_C().ml_cylinder_energy_slot(ctypes.byref(count)))
    if count.value != len(TERMS):
        raise AssertionError(f"the C plugin has {count.value} energy terms, {len(TERMS)} named")
    return slot


class EnergyLayout:
    """Where each pinned cylinder's energies live in ``d.plugin_state``.

    Args:
        model: the plant's model (actuator i < n drives joint i).
        actuators: the arm's actuator models, one per joint.
    """

    def __init__(self, model: mujoco.MjModel, actuators: Sequence[object]) -> None:
        from maniplab.actuators.hydraulic.pinned import PinnedCylinder

        self.n = len(actuators)
        joints = [j for j, a in enumerate(actuators)
                  if isinstance(a, PinnedCylinder) and model.actuator_plugin[j] >= 0]
        self.joints = np.array(joints, dtype=int)
        if not joints:
            self.adrs = np.zeros((0, len(TERMS)), dtype=int)
            return
        slot = _slot()
        starts = [int(model.plugin_stateadr[model.actuator_plugin[j]]) + slot for j in joints]
        self.adrs = np.array(starts)[:, None] + np.arange(len(TERMS))[None, :]

    def __bool__(self) -> bool:
        return len(self.joints) > 0

    def zero(self, data: mujoco.MjData) -> None:
        """Start counting: every cylinder's energies to 0."""
        data.plugin_state[self.adrs.ravel()] = 0.0

    def read(self, plugin_state: np.ndarray) -> dict[str, np.ndarray]:
        """The energy signals from recorded plugin states (m, npluginstate): name -> (m, n), J,
        NaN at joints without a pinned cylinder."""
        out = {}
        for k, name in enumerate(SIGNALS):
            full = np.full((len(plugin_state), self.n), np.nan)
            full[:, self.joints] = plugin_state[:, self.adrs[:, k]]
            out[name] = full
        return out
