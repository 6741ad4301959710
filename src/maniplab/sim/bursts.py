"""Hose bursts: a run's scenario that opens a cylinder's line to the atmosphere at a given time.

A burst line spills its oil at the tank's pressure from then on: the valve's oil into that line is
lost, and the chamber drains through its load-holding valve (a counterbalance valve or a
pilot-operated check, shut while its pilot stays low: only its seat leaks) or, without one,
through the hose's open end (``maniplab_native/chambers.h``, ``ml_way_out``). It is what a
designer checks a holding valve with: a load over people may not drop when a hose fails (EN 12999
asks it of loader cranes' holding valves), and the run's health verdict says how far the piston
moved after the burst (:func:`drop_findings`).

A burst is written ``JOINT:LINE@TIME``: the joint of a pinned cylinder, its line ``a`` (cap side)
or ``b`` (rod side), and the time in seconds on the run's clock (``lift:a@1.5``; a run of a new
plant starts at 0). The run loop
passes the times to the engine plugin in ``mjData.userdata`` (slot 2 + 2 × actuator + line), so
the exported model and the FMU take the same law; the burst takes effect from the first step that
starts at or after its time.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

import numpy as np

from maniplab.sim.errors import InputError
from maniplab.sim.findings import Finding, Severity
from maniplab.spec import models_of

if TYPE_CHECKING:
    from maniplab.sim.plant import Plant
    from maniplab.sim.run import Run
    from maniplab.spec import ManipulatorSpec

HELD = 1e-3
"""m: a piston that moves less than this after its line burst holds its load (a holding valve
may let it creep by its documented leakage only)."""

_FORM = re.compile(r"^\s*([^:@\s]+)\s*:\s*([abAB])\s*@\s*(\S+)\s*$")


@dataclasses.dataclass(frozen=True)
class Burst:
    """One line that bursts.

    Attributes:
        joint: the joint whose cylinder's line bursts.
        line: "a" (cap side) or "b" (rod side).
        time: when, s on the run's clock (positive).
    """

    joint: str
    line: str
    time: float

    def __str__(self) -> str:
        return f"{self.joint}:{self.line}@{self.time:g}"


def parse(text: str) -> Burst:
    """``JOINT:LINE@TIME`` as a :class:`Burst` (not yet checked against an arm).

    Raises:
        InputError: another form, or a time that is not a positive number.
    """
    match = _FORM.match(str(text))
    if match is None:
        raise InputError(f"burst {text!r}: expected JOINT:LINE@TIME, e.g. lift:a@1.5 (LINE a for "
                         "the cap side, b for the rod side; TIME in s)")
    joint, line, when = match.groups()
    try:
        time = float(when)
    except ValueError:
        raise InputError(f"burst {text!r}: the time {when!r} is not a number of seconds") from None
    if not (math.isfinite(time) and time > 0.0):
        raise InputError(f"burst {text!r}: the time must be a positive number of seconds")
    return Burst(joint, line.lower(), time)


def checked(spec: ManipulatorSpec, bursts: Iterable[Burst | str]) -> list[Burst]:
    """The bursts, each checked against the arm: a joint whose actuator has that line.

    Raises:
        InputError: a malformed burst, an unknown joint, or a joint without hydraulic lines.
    """
    models = dict(zip(spec.joint_names, models_of(spec), strict=True))
    out = []
    for item in bursts:
        burst = item if isinstance(item, Burst) else parse(item)
        if burst.joint not in models:
            raise InputError(f"burst {burst}: no joint {burst.joint!r}; expected one of "
                             f"{', '.join(spec.joint_names)}")
        lines = getattr(models[burst.joint], "lines", ())
        if burst.line not in lines:
            raise InputError(f"burst {burst}: joint {burst.joint}'s actuator has no hydraulic "
                             "lines to burst (only a pinned two-chamber cylinder has: a and b)")
        out.append(burst)
    return out


def write(plant: Plant, bursts: Iterable[Burst]) -> None:
    """Tell the engine plugin when each line bursts (``mjData.userdata``)."""
    names = plant.spec.joint_names
    for burst in bursts:
        plant.data.userdata[2 + 2 * names.index(burst.joint) + "ab".index(burst.line)] = burst.time


def of_run(run: Run) -> list[Burst]:
    """The bursts a run was made with (``meta["bursts"]``)."""
    return [parse(text) for text in (run.meta or {}).get("bursts", ())]


def drops(run: Run) -> list[tuple[Burst, float, float]]:
    """For each burst of the run: (burst, the largest travel of that cylinder's piston after
    it, m, and the time it was watched for, s). The piston's travel is what the holding valve
    governs; the other joints' drift (their own valves' and drives' leakage) is theirs."""
    if "stroke" not in run:
        return []
    t, stroke = np.asarray(run.t, dtype=float), np.asarray(run["stroke"], dtype=float)
    names = run.spec.joint_names
    out = []
    for burst in of_run(run):
        after = t >= burst.time
        if after.sum() < 2:
            continue
        travel = stroke[after, names.index(burst.joint)]
        moved = float(np.nanmax(np.abs(travel - travel[0])))
        out.append((burst, moved, float(t[-1] - t[after][0])))
    return out


def drop_findings(run: Run) -> list[Finding]:
    """A failure for each burst after which its cylinder's piston moved more than
    :data:`HELD`."""
    out = []
    valves = {joint.name: getattr(joint.actuator, "holding", None)
              for joint in run.spec.joints}
    for burst, moved, watched in drops(run):
        if moved <= HELD:
            continue
        valve = getattr(valves.get(burst.joint), burst.line, None)
        advice = ("nothing holds it: a counterbalance valve or a pilot-operated check on the "
                  "load-holding chamber (actuator.holding)" if valve is None else
                  "its holding valve let the oil out: its setting below the load's pressure, its "
                  "seat's leakage, or its pilot opened it (the other line's pressure, or the "
                  "piston's leakage into it)")
        out.append(Finding(
            Severity.FAILURE, "burst", burst.joint,
            f"the piston moved {moved * 1e3:.4g} mm in the {watched:.3g} s after line "
            f"{burst.line.upper()} burst at {burst.time:g} s", advice))
    return out


def describe(bursts: Iterable[Burst]) -> list[str]:
    """The bursts as run metadata (``JOINT:LINE@TIME``)."""
    return [str(b) for b in bursts]


def from_any(value: Any) -> list[Burst | str]:
    """``simulate``'s ``bursts`` argument as a list (one burst or several)."""
    if value is None:
        return []
    if isinstance(value, (str, Burst)):
        return [value]
    return list(value)
