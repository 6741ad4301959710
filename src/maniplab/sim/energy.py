"""The energy of a run: where each pinned cylinder's hydraulic power went.

Each pinned cylinder's engine plugin (``maniplab_native/cylinder.c``) accumulates, within its own
step, the energy the supply delivered through its valve section and where it went: the losses
across the meter-in orifice, its pressure compensator, the meter-out orifice, the piston's
leakage, the relief and anti-cavitation valves; the energy the return oil carries into the tank
line; the work on the piston; the energy stored by compressing the oil. Every term is taken at
the same instants of the chambers' integration, so that

    pump = meter_in + compensator + meter_out + cushion + holding + burst + leakage + relief
           + anticavitation + tank + work + compression

holds to round-off, as the chambers' continuity multiplied by their pressures does at each instant.
The recorder reads the accumulators from the recorded plugin states and gives them as the run's
signals ``E_<term>`` (J, since the run's start, NaN at joints without a pinned cylinder).
"""

from __future__ import annotations

import ctypes
import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from maniplab.clib import Functions
from maniplab.errors import ManiplabError
from maniplab.spec import model_of

if TYPE_CHECKING:
    import mujoco

    from maniplab.sim.run import Run

TERMS = ("pump", "meter_in", "compensator", "meter_out", "leakage", "relief", "anticavitation",
         "tank", "work", "compression", "cushion", "holding", "burst")
"""The energy terms, in the order of the C accumulators (``chambers.h``, ``ML_E_*``)."""

LOSSES = ("meter_in", "compensator", "meter_out", "cushion", "holding", "burst", "leakage",
          "relief", "anticavitation")
"""The terms that are losses (heat in the oil)."""

SIGNALS = tuple(f"E_{term}" for term in TERMS)
"""The run's energy signals, J."""

SUPPLY_INTEGRAL = "p_supply_integral"
"""The run's signal of the supply pressure each section sees, integrated over time, Pa·s (a fixed
displacement pump's energy is its flow times this)."""

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
    "cushion": "lost in the end cushions' throttles",
    "holding": "lost across the load-holding (counterbalance, pilot-operated check) valves",
    "burst": "spilled from a burst line",
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
        self.n = len(actuators)
        joints = [j for j, a in enumerate(actuators)
                  if getattr(a, "energy", None) == "plugin" and model.actuator_plugin[j] >= 0]
        self.joints = np.array(joints, dtype=int)
        if not joints:
            self.adrs = np.zeros((0, len(TERMS) + 1), dtype=int)
            return
        slot = _slot()
        starts = [int(model.plugin_stateadr[model.actuator_plugin[j]]) + slot for j in joints]
        self.adrs = np.array(starts)[:, None] + np.arange(len(TERMS) + 1)[None, :]

    def __bool__(self) -> bool:
        return len(self.joints) > 0

    def zero(self, data: mujoco.MjData) -> None:
        """Start counting: every cylinder's energies to 0."""
        data.plugin_state[self.adrs.ravel()] = 0.0

    def read(self, plugin_state: np.ndarray) -> dict[str, np.ndarray]:
        """The energy signals (and :data:`SUPPLY_INTEGRAL`) from recorded plugin states (m,
        npluginstate): name -> (m, n), J (Pa·s), NaN at joints without a pinned cylinder."""
        out = {}
        for k, name in enumerate((*SIGNALS, SUPPLY_INTEGRAL)):
            full = np.full((len(plugin_state), self.n), np.nan)
            full[:, self.joints] = plugin_state[:, self.adrs[:, k]]
            out[name] = full
        return out


@dataclasses.dataclass(frozen=True)
class EnergyReport:
    """Where a run's hydraulic energy went, per pinned cylinder (:func:`energy_report`).

    Attributes:
        label: the run's label.
        joints: the joints with a pinned cylinder, in the spec's order.
        terms: term (:data:`TERMS`) -> energy of each of those joints over the run, J.
        pump_relief: the energy a fixed displacement pump put over its relief valve (the flow
            the sections did not take, at the pump's pressure), J; 0 for a variable pump.
        unaccounted: joints with a hydraulic actuator whose energy is not accounted (lumped
            cylinders).
    """

    label: str
    joints: tuple[str, ...]
    terms: dict[str, np.ndarray]
    pump_relief: float = 0.0
    unaccounted: tuple[str, ...] = ()

    def total(self, term: str) -> float:
        """A term summed over the joints, J."""
        return float(np.sum(self.terms[term]))

    @property
    def pump(self) -> float:
        """The energy the pump delivered, J: through the sections, and over its own relief."""
        return self.total("pump") + self.pump_relief

    @property
    def losses(self) -> float:
        """Every loss, J: the sections' (:data:`LOSSES`) and the pump's relief."""
        return sum(self.total(k) for k in LOSSES) + self.pump_relief

    @property
    def residual(self) -> float:
        """The pump's energy minus where it went (0 up to round-off), J."""
        return self.total("pump") - sum(self.total(k) for k in TERMS if k != "pump")

    def as_dict(self) -> dict[str, object]:
        """The report as JSON-ready data (J)."""
        return {"label": self.label, "joints": list(self.joints),
                "terms": {k: [float(x) for x in v] for k, v in self.terms.items()},
                "pump_relief": self.pump_relief, "pump": self.pump, "losses": self.losses,
                "residual": self.residual, "unaccounted": list(self.unaccounted)}

    def table(self) -> str:
        """A text table: one row per term, a column per joint and their total, kJ."""
        head = ["term", *self.joints, "total"]
        rows = [[f"{term}", *(f"{x / 1e3:.3f}" for x in self.terms[term]),
                 f"{self.total(term) / 1e3:.3f}"] for term in TERMS]
        if self.pump_relief:
            rows.append(["pump relief", *("" for _ in self.joints), f"{self.pump_relief / 1e3:.3f}"])
        widths = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]
        lines = ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in
                           enumerate(zip(r, widths))) for r in [head, *rows]]
        lines.append(f"pump {self.pump / 1e3:.3f} kJ, losses {self.losses / 1e3:.3f} kJ, work on "
                     f"the pistons {self.total('work') / 1e3:.3f} kJ (negative: the loads did "
                     f"work), balance residual {self.residual:.1e} J")
        if self.unaccounted:
            lines.append("not accounted (lumped cylinders): " + ", ".join(self.unaccounted))
        return "\n".join(lines)


def energy_report(run: Run) -> EnergyReport:
    """Where ``run``'s hydraulic energy went, from its ``E_<term>`` signals (their change over
    the run) and, for a fixed displacement pump, its pressure's time integral.

    Raises:
        ManiplabError: the run has no pinned cylinder (no energy signals), in one line.
    """
    spec = run.spec
    if "E_pump" not in run.signals:
        raise ManiplabError(f"run {run.label!r} ({spec.name}) has no pinned cylinder: its energy "
                            "is not accounted (only pinned cylinders' is)")
    first = run["E_pump"][0]
    joints = np.flatnonzero(np.isfinite(first))
    terms = {t: run[f"E_{t}"][-1, joints] - run[f"E_{t}"][0, joints] for t in TERMS}
    pump_relief = 0.0
    if spec.supply is not None and spec.supply.displacement == "fixed":
        seen = run[SUPPLY_INTEGRAL][-1, joints] - run[SUPPLY_INTEGRAL][0, joints]
        pump_relief = max(0.0, float(spec.supply.max_flow * np.max(seen)) - float(
            np.sum(terms["pump"])))
    names = tuple(spec.joints[j].name for j in joints)
    lumped = tuple(j.name for j in spec.joints if model_of(j).energy == "unaccounted")
    return EnergyReport(run.label, names, terms, pump_relief, lumped)
