"""The lowering oscillation of a counterbalance valve, found in a run's signals.

A load lowered through a counterbalance valve is metered by the valve's opening, which its pilot
(the other line's pressure) sets. When the load runs ahead of the oil the section feeds the other
chamber, the pilot pressure falls, the valve closes, the load is braked, the pilot pressure
rises, the valve opens: with a high pilot ratio, a pressure-compensated section (whose flow does
not yield to the pressure) and a heavy, lightly damped boom, this loop does not settle and the
boom lowers in jerks, the holding chamber's pressure swinging at the boom's hydraulic frequency.
Valve makers recommend low ratios (1.5:1 to 3:1) for unstable loads such as crane booms; a high
ratio (8:1 to 10:1) opens the valve with little pilot pressure and saves energy where the load is
stable.

The check (:func:`oscillations`): while a chamber with a counterbalance valve drains (the spool
open to its meter-out edge) for longer than :data:`SETTLE` plus :data:`WINDOW`, its pressure over
the part after :data:`SETTLE`, its trend (a straight line) removed, swings by more than
:data:`SWING` of its mean, through at least :data:`CYCLES` full cycles, and the swing of the
window's second half is at least :data:`SUSTAINED` of its first half's: a sustained oscillation,
not a decaying transient.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from maniplab.sim.findings import Finding, Severity

if TYPE_CHECKING:
    from maniplab.sim.run import Run

SETTLE = 0.3
"""s: the start of a lowering left out (the valve's opening transient)."""

WINDOW = 0.5
"""s: the least time a lowering is watched for, after :data:`SETTLE`."""

SWING = 0.05
"""The amplitude (half the swing) over the chamber's mean pressure beyond which it is reported."""

CYCLES = 3
"""The least number of full cycles within the window."""

SUSTAINED = 0.5
"""The second half's amplitude over the first half's at least: the oscillation does not decay."""


@dataclasses.dataclass(frozen=True)
class Oscillation:
    """A sustained oscillation of a holding chamber's pressure while lowering.

    Attributes:
        joint: the joint's name.  chamber: "A" or "B".
        frequency: Hz.  amplitude: half the swing, Pa.  mean: the mean pressure, Pa.
        start, end: the window watched, s.
    """

    joint: str
    chamber: str
    frequency: float
    amplitude: float
    mean: float
    start: float
    end: float


def oscillations(run: Run) -> list[Oscillation]:
    """The sustained pressure oscillations of every chamber that has a counterbalance valve
    (a ``hold_a``/``hold_b`` signal) while it drains."""
    if "spool" not in run:
        return []
    t = np.asarray(run.t, dtype=float)
    out = []
    for side, way in (("a", -1.0), ("b", 1.0)):
        if f"hold_{side}" not in run:
            continue
        holds = np.asarray(run[f"hold_{side}"], dtype=float)
        pressures = np.asarray(run[f"p{side.upper()}"], dtype=float)
        spool = np.asarray(run["spool"], dtype=float)
        for j, name in enumerate(run.spec.joint_names):
            if not np.isfinite(holds[:, j]).any():
                continue
            for start, end in _runs(way * spool[:, j] > 0.0):
                found = _oscillation(t[start:end], pressures[start:end, j])
                if found is not None:
                    out.append(Oscillation(name, side.upper(), *found))
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """The [start, end) index ranges where ``mask`` holds."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def _oscillation(t: np.ndarray, p: np.ndarray) -> tuple[float, float, float, float, float] | None:
    """(frequency, amplitude, mean, start, end) of a sustained oscillation of p(t) after
    :data:`SETTLE`, or None."""
    if len(t) < 8 or t[-1] - t[0] < SETTLE + WINDOW:
        return None
    keep = t >= t[0] + SETTLE
    t, p = t[keep], p[keep]
    swing = p - np.polyval(np.polyfit(t - t[0], p, 1), t - t[0])
    amplitude = float(np.sqrt(2.0) * np.std(swing))
    mean = float(np.mean(p))
    if not amplitude > SWING * abs(mean):
        return None
    half = len(swing) // 2
    if np.std(swing[half:]) < SUSTAINED * np.std(swing[:half]):
        return None
    cycles = _crossings(swing, 0.3 * amplitude) / 2.0
    if cycles < CYCLES:
        return None
    return cycles / float(t[-1] - t[0]), amplitude, mean, float(t[0]), float(t[-1])


def _crossings(x: np.ndarray, band: float) -> int:
    """How often x passes from below -band to above +band or back (a crossing with hysteresis,
    so that noise about zero is not counted)."""
    state, count = 0, 0
    for value in x:
        side = 1 if value > band else (-1 if value < -band else 0)
        if side and side != state:
            count += state != 0
            state = side
    return count


def findings(run: Run) -> list[Finding]:
    """A warning for each sustained lowering oscillation."""
    out = []
    for o in oscillations(run):
        side = o.chamber.lower()
        valve = getattr(getattr(run.spec.joint(o.joint).actuator, "holding", None), side, None)
        ratio = f" than its {valve.pilot_ratio:g}:1" if valve is not None else ""
        out.append(Finding(
            Severity.WARNING, "lowering", o.joint,
            f"the {o.chamber} side's pressure oscillates at {o.frequency:.3g} Hz, "
            f"±{o.amplitude / 1e5:.3g} bar about {o.mean / 1e5:.4g} bar, while lowering "
            f"through its counterbalance valve ({o.start:.3g}-{o.end:.3g} s)",
            f"a lower pilot ratio{ratio} (actuator.holding.{side}.pilot_ratio), a slower "
            "lowering, or a section without pressure compensation damps it"))
    return out
