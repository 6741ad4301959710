"""The step a run needs for its accuracy, measured on the arm.

The stability limit (:mod:`maniplab.mjcf_gen.timestep`) says which steps a run survives; this
module says which ones are accurate. On the arm's own model, from mid-range (held against gravity),
every actuator's command steps to +half its range, then to -half, then back to 0
(:func:`excitation`): the valves open both ways, the oil springs ring, the chambers fill and
empty. The run is made at a step h and at h/2; with the plant's second-order schemes (the
exponential step of the hydraulic states, ``maniplab_native/stiff.h``, coupled to MuJoCo's RK4)
the error of the run at h is 4/3 of their difference (Richardson), per signal relative to its
range. The derived step is the largest of 1, 2, 5 × 10^k s within the stability limit whose
estimated error, divided by :data:`SAFETY`, is at most :data:`TOLERANCE` for the joint positions
and every actuator state. The result is cached on disk, keyed by the spec and the sources of the
plant (``<cache>/steps/``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from maniplab.atomic import write_text
from maniplab.mjcf_gen.timestep import round_down
from maniplab.spec import ManipulatorSpec

TOLERANCE = 1e-3
"""The largest error of a derived step's run, per signal, relative to the signal's range."""

SAFETY = 0.5
"""The estimated error may reach this share of :data:`TOLERANCE` only."""

DURATION = 0.3
"""The excitation's length, s."""

SWITCH = (0.05, 0.15, 0.25)
"""When the commands step to +half, to -half and back to 0, s."""

SMALLEST = 1e-5
"""The finest step the search tries, s: an arm that needs a finer one is refused (a 10 s run
would take a million steps), naming the joint, the state and the step it needs."""


class StepWarning(UserWarning):
    """A step given explicitly is coarser than the arm's accuracy allows."""

_MEASURING = False  # set while this module's own runs build plants (they give their step)


@dataclasses.dataclass(frozen=True)
class AccurateStep:
    """The step the arm's accuracy allows.

    Attributes:
        dt: the step, s.
        error: the estimated error of a run at dt, relative to the worst signal's range.
        signal: that signal (e.g. "pA"), or "" when nothing limits the step.
        joint: its joint's name, or "".
        needs: the step the tolerance needs when even :data:`SMALLEST` misses it (the error
            taken as second order in the step), else equal to ``dt``.
    """

    dt: float
    error: float = 0.0
    signal: str = ""
    joint: str = ""
    needs: float = 0.0

    @property
    def met(self) -> bool:
        """Whether ``dt`` keeps the excitation within the tolerance."""
        return self.error / SAFETY <= TOLERANCE

    def describe(self) -> str:
        """E.g. "joint lift's pA is 2.1e-3 of its range off at 1e-3 s"."""
        if not self.signal:
            return f"{self.dt:g} s (no actuator state limits the step)"
        return (f"{self.dt:g} s: joint {self.joint}'s {self.signal} within {self.error:.2g} of "
                f"its range")


def measuring() -> bool:
    """Whether the plant being built is one of this module's own runs (which set their step)."""
    return _MEASURING


@contextlib.contextmanager
def _measuring() -> Iterator[None]:
    global _MEASURING
    before, _MEASURING = _MEASURING, True
    try:
        yield
    finally:
        _MEASURING = before


def accurate_step(spec: ManipulatorSpec, stable: float) -> AccurateStep:
    """The largest step at most ``stable`` (s, the stability limit's default step) that keeps
    the excitation's run within the tolerance; cached on disk."""
    if stable < SMALLEST:  # too fine to measure affordably: the stability limit's step
        return AccurateStep(stable, needs=stable)
    path = _cache_path(spec, stable)
    try:
        found = AccurateStep(**json.loads(path.read_text()))
        if found.needs > 0.0:
            return found
    except (OSError, ValueError, TypeError):
        pass
    found = _search(spec, stable)
    with contextlib.suppress(OSError):
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, json.dumps(dataclasses.asdict(found)))
    return found


def check(found: AccurateStep, dt: float | None, mujoco_step: float, source: str | None) -> None:
    """Refuse an arm whose accuracy needs a step below :data:`SMALLEST` (a derived step), or warn
    when an explicit ``dt`` makes MuJoCo's steps (``mujoco_step``, s) coarser than ``found``."""
    import warnings

    from maniplab.sim.errors import InstabilityError

    where = f" in {source}" if source else ""
    if dt is None and not found.met:
        raise InstabilityError(
            f"joint {found.joint}'s {found.signal} needs dt <= {found.needs:.2g} s to stay within "
            f"{TOLERANCE:g} of its range, below the {SMALLEST:g} s a simulation can afford: check "
            f"that actuator's parameters{where} (a tiny oil volume or a huge valve?), or give "
            "dt explicitly to run less accurately", time=0.0, joint=found.joint or None,
            dt=found.dt, resolved=True)
    if dt is not None and mujoco_step > found.needs * 1.000001:
        warnings.warn(f"dt {mujoco_step:g} s is coarser than the {found.needs:.2g} s that keeps "
                      f"joint {found.joint}'s {found.signal} within {TOLERANCE:g} of its range",
                      StepWarning, stacklevel=3)


def _search(spec: ManipulatorSpec, stable: float) -> AccurateStep:
    h = stable
    while True:
        coarse, names = _run(spec, h, h)
        if not names:
            return AccurateStep(h, needs=h)  # no actuator states: the mechanics alone
        fine, _ = _run(spec, h / 2.0, h)
        error, signal, joint = _estimate(coarse, fine)
        if error / SAFETY <= TOLERANCE or h <= SMALLEST * 1.000001:
            needs = h * min(1.0, math.sqrt(SAFETY * TOLERANCE / error)) if error > 0 else h
            return AccurateStep(h, error, signal, spec.joint_names[joint] if signal else "",
                                needs)
        h = round_down(h * 0.999)  # the next 1, 2, 5 × 10^k below


def excitation(spec: ManipulatorSpec, limits: np.ndarray) -> dict[str | int, Any]:
    """Each commanded joint's input: half its command range at SWITCH[0], minus half at
    SWITCH[1], 0 at SWITCH[2] (a joint without a command limit gets none)."""
    from maniplab.sim import signals

    inputs: dict[str | int, Any] = {}
    for j, limit in enumerate(limits):
        if math.isfinite(limit) and limit > 0.0:
            a = 0.5 * float(limit)
            inputs[j] = (signals.step(a, SWITCH[0]) + signals.step(-2.0 * a, SWITCH[1])
                         + signals.step(a, SWITCH[2]))
    return inputs


def _run(spec: ManipulatorSpec, h: float, sample: float) -> tuple[dict[str, np.ndarray],
                                                                  list[str]]:
    """The excitation's run at the step h, recorded every ``sample`` s, by signal (each (K, n)):
    the joint positions and the actuator states; and the actuator states' names."""
    from maniplab.sim.plant import Plant
    from maniplab.sim.simulate import simulate

    with _measuring():
        plant = Plant(smooth(spec), dt=h)
    start = np.array([0.5 * (j.limits[0] + j.limits[1]) if j.limits else 0.0
                      for j in spec.joints])
    limits = np.asarray(plant.command_limit, dtype=float)
    run = simulate(plant, inputs=excitation(spec, limits), duration=DURATION,
                   initial={"q": start, "dP": "gravity"}, sample_dt=sample)
    names = [name for name in plant.state_names if name in run.signals]
    return {name: np.asarray(run[name]) for name in ["q", *names]}, names


def smooth(spec: ManipulatorSpec) -> ManipulatorSpec:
    """``spec`` without the stick/slip events of its hybrid friction (no Coulomb or stiction,
    the viscous part kept): the step in which such an event falls is a matter of the event's
    location, first order in any fixed-step scheme, not of the integration's accuracy."""
    from maniplab.friction.params import FrictionModel

    changes = {}
    for joint in spec.joints:
        if joint.friction.model is FrictionModel.hybrid:
            changes[f"joints.{joint.name}.friction.coulomb"] = 0.0
            changes[f"joints.{joint.name}.friction.static"] = 0.0
    return spec.with_overrides(changes) if changes else spec


def _estimate(coarse: dict[str, np.ndarray],
              fine: dict[str, np.ndarray]) -> tuple[float, str, int]:
    """4/3 of the largest difference between the runs at h and h/2 (recorded at the same
    times), relative to the signal's range in the finer run: (error, signal, joint)."""
    worst = (0.0, "", 0)
    for name, finer in fine.items():
        diff = np.abs(coarse[name] - finer)
        span = np.ptp(finer, axis=0)
        scale = np.maximum(span, 1e-3 * np.abs(finer).max(axis=0) + 1e-300)
        with np.errstate(invalid="ignore"):
            errors = np.nan_to_num(4.0 / 3.0 * diff.max(axis=0) / scale, nan=0.0)
        j = int(np.argmax(errors))
        if errors[j] > worst[0]:
            worst = (float(errors[j]), name, j)
    return worst


def _cache_path(spec: ManipulatorSpec, stable: float) -> Path:
    from maniplab_native.build import cache_root, sources

    digest = hashlib.sha256()
    spec_data = spec.to_dict()
    spec_data.pop("control", None)
    spec_data.pop("name", None)
    digest.update(json.dumps(spec_data, sort_keys=True).encode())
    digest.update(repr((stable, TOLERANCE, SAFETY, DURATION, SWITCH)).encode())
    here = Path(__file__).resolve().parent
    for source in [*sources(), *sorted(here.glob("*.py")),
                   *sorted((here.parent / "actuators").rglob("*.py"))]:
        digest.update(source.name.encode() + b"\0" + source.read_bytes())
    return cache_root() / "steps" / f"{digest.hexdigest()[:32]}.json"
