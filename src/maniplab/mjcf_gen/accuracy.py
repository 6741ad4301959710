"""The step a run needs for its accuracy, measured on the arm.

The stability limit (:mod:`maniplab.mjcf_gen.timestep`) says which steps a run survives; this
module says which ones are accurate. On the arm's own MuJoCo model (its engine plugins, so the
states take the same steps as in the plant, the exported file and the FMU), from mid-range, every
actuator's command steps to +half its range, then to -half, then back to 0 (:func:`excitation`):
the arm sags onto its oil springs, the valves open both ways, the chambers fill and empty. The run
is made at a step h and at h/2; with the plant's second-order schemes (the exponential step of the
hydraulic states, ``maniplab_native/stiff.h``, coupled to MuJoCo's RK4) the error of the run at h
is 4/3 of their difference (Richardson), per signal relative to its range. The derived step is the
largest of 1, 2, 5 × 10^k s within the stability limit whose estimated error, divided by
:data:`SAFETY`, is at most :data:`TOLERANCE` for the joint positions and every actuator state.

The measurement leaves out stick/slip friction (and the plant's friction automaton with it): where
a joint sticks is an event located to the step, first order in any fixed-step scheme, a matter of
event location rather than of integration (the simulating page says so). The result is cached on
disk, keyed by the spec and the sources that build and integrate the model (``<cache>/steps/``).
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import functools
import hashlib
import json
import math
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np
from mujoco import rollout

from maniplab.atomic import write_text
from maniplab.mjcf_gen.timestep import round_down
from maniplab.spec import ManipulatorSpec, model_of

TOLERANCE = 1e-3
"""The largest error of a derived step's run, per signal, relative to the signal's range."""

SAFETY = 0.5
"""The estimated error may reach this share of :data:`TOLERANCE` only."""

AMPLITUDE = 0.5
"""The share of each command range the excitation asks for: typical operation (at full range a
crane's steps come out 2 to 5 times finer, and a scenario such as a wide-open valve lowering a
load into cavitation is still not the excitation's: its pressures reach 2.5e-3 of their range at
the derived step; see the simulating page)."""

DURATION = 0.3
"""The excitation's length, s."""

SWITCH = (0.05, 0.15, 0.25)
"""When the commands step to +half, to -half and back to 0, s."""

POSITION_FLOOR = 1e-3
"""A joint position's range counts as at least this, rad or m: a joint the excitation barely
moves (friction holding it) is not asked to be accurate to a thousandth of its micrometres."""

SMALLEST = 1e-5
"""The finest step the search tries, s: an arm that needs a finer one is refused (a 10 s run
would take a million steps), naming the joint, the state and the step it needs."""


class StepWarning(UserWarning):
    """A step given explicitly is coarser than the arm's accuracy allows."""


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
        """E.g. "0.001 s: joint boom's pB within 0.00032 of its range"."""
        if not self.signal:
            return f"{self.dt:g} s (no actuator state limits the step)"
        return (f"{self.dt:g} s: joint {self.joint}'s {self.signal} within {self.error:.2g} of "
                f"its range")


@functools.lru_cache(maxsize=256)
def accurate_step(spec: ManipulatorSpec, stable: float,
                  compile_arm: Callable[[ManipulatorSpec], mujoco.MjModel]) -> AccurateStep:
    """The largest step at most ``stable`` (s, the stability limit's default step) that keeps
    the excitation's run within the tolerance; cached on disk (and in the process).
    ``compile_arm(spec)`` compiles an arm's MuJoCo model (:mod:`~maniplab.mjcf_gen.builder`'s).
    An arm with actuators written in Python (whose states MuJoCo integrates through the plant's
    callbacks) is not measured: the stability limit's step."""
    python = any(model_of(j).mujoco_plugin() is None and model_of(j).states for j in spec.joints)
    if stable < SMALLEST or python:  # too fine to measure affordably, or not in plain MuJoCo
        return AccurateStep(stable, needs=stable)
    path = _cache_path(spec, stable)
    try:
        return AccurateStep(**json.loads(path.read_text()))
    except (OSError, ValueError, TypeError):
        pass
    found = _search(spec, stable, compile_arm)
    with contextlib.suppress(OSError):
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, json.dumps(dataclasses.asdict(found)))
    return found


def _search(spec: ManipulatorSpec, stable: float,
            compile_arm: Callable[[ManipulatorSpec], mujoco.MjModel]) -> AccurateStep:
    model, labels = _model(spec, compile_arm)
    if not labels:
        return AccurateStep(stable, needs=stable)  # no actuator states: the mechanics alone
    h = stable
    while True:
        columns = sorted(labels)
        floor = np.array([POSITION_FLOOR if labels[c][0] == "q" else 0.0 for c in columns])
        error, k = _estimate(_run(model, h, h)[:, columns], _run(model, h / 2.0, h)[:, columns],
                             floor)
        signal, joint = labels[columns[k]] if error > 0.0 else ("", "")
        if error / SAFETY <= TOLERANCE or h <= SMALLEST * 1.000001:
            needs = h * min(1.0, math.sqrt(SAFETY * TOLERANCE / error)) if error > 0 else h
            return AccurateStep(h, error, signal, joint, needs)
        h = round_down(h * 0.999)  # the next 1, 2, 5 × 10^k below


def excitation(limits: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The commands at the times t (s, (K,)): AMPLITUDE of each command range from SWITCH[0],
    minus that from SWITCH[1], 0 from SWITCH[2] (0 where a command has no limit),
    (K, len(limits))."""
    level = np.where(np.isfinite(limits), AMPLITUDE * limits, 0.0)
    sign = sum(w * (t + 1e-9 >= switch) for w, switch in zip((1.0, -2.0, 1.0), SWITCH))
    return np.outer(sign, level)


def _model(spec: ManipulatorSpec, compile_arm: Callable[[ManipulatorSpec], mujoco.MjModel]
           ) -> tuple[mujoco.MjModel, dict[int, tuple[str, str]]]:
    """The MuJoCo model of ``spec`` without stick/slip friction, and a label (state, joint) for
    each column of :func:`_run` the estimate compares: the joint positions and every state of
    the joints' actuators (none when the actuators have none). LuGre's bristle deflection is not
    compared: it is a state of friction, micrometres that matter through the force they make,
    and its accuracy shows in the joint's position (the friction page gives its figures)."""
    model = compile_arm(smooth(spec))
    labels = {j: ("q", name) for j, name in enumerate(spec.joint_names)}
    for i in range(min(model.nu, spec.n)):
        names = model_of(spec.joints[i]).states
        for k in range(model.actuator_actnum[i]):
            label = names[k] if k < len(names) else f"state {k}"
            labels[model.nq + model.actuator_actadr[i] + k] = (label, spec.joint_names[i])
    return model, labels if len(labels) > spec.n else {}


def _run(model: mujoco.MjModel, h: float, sample: float) -> np.ndarray:
    """The excitation's run at the step h from mid-range (the actuators' initial states, the
    keyframe ``initial``), every ``sample`` s: the joint positions and the actuator states,
    (K, nq + na)."""
    m = copy.copy(model)
    m.opt.timestep = h
    data = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, data, 0)
    low, high = m.jnt_range[:, 0], m.jnt_range[:, 1]
    data.qpos[:] = np.where(m.jnt_limited, 0.5 * (low + high), 0.0)
    mujoco.mj_forward(m, data)
    spec_state = mujoco.mjtState.mjSTATE_FULLPHYSICS
    start = np.empty(mujoco.mj_stateSize(m, spec_state))
    mujoco.mj_getState(m, data, start, spec_state)
    steps = round(DURATION / h)
    limits = np.where(m.actuator_ctrllimited, np.abs(m.actuator_ctrlrange).max(axis=1), np.inf)
    control = excitation(limits, np.arange(steps) * h)
    states, _ = rollout.rollout(m, data, start, control[None], nstep=steps)
    every = max(1, round(sample / h))
    picked = np.concatenate([start[None], states[0]])[::every]
    nq, na = m.nq, m.na
    return np.concatenate([picked[:, 1:1 + nq], picked[:, 1 + nq + m.nv:1 + nq + m.nv + na]],
                          axis=1)


def smooth(spec: ManipulatorSpec) -> ManipulatorSpec:
    """``spec`` without the stick/slip events of its hybrid friction (friction model none, and
    no Coulomb or static rod friction): where a joint sticks is an event located to the step,
    first order in any fixed-step scheme, not a matter of the integration's accuracy. LuGre's
    smooth bristles and the rods' viscous friction stay."""
    from maniplab.friction.params import FrictionModel

    changes: dict[str, object] = {f"joints.{joint.name}.friction.model": "none"
                                  for joint in spec.joints
                                  if joint.friction.model is FrictionModel.hybrid}
    for joint in spec.joints:
        rod = joint.rod_friction
        if rod is not None and rod.sticks:
            path = f"joints.{joint.name}.actuator.cylinder.friction"
            changes.update({f"{path}.coulomb": 0.0, f"{path}.static": 0.0})
    return spec.with_overrides(changes) if changes else spec


def _estimate(coarse: np.ndarray, fine: np.ndarray, floor: np.ndarray) -> tuple[float, int]:
    """4/3 of the largest difference between the runs at h and h/2 (recorded at the same
    times), relative to each signal's range in the finer run, at least ``floor`` (per column):
    (error, column)."""
    span = np.maximum(np.ptp(fine, axis=0), floor)
    scale = np.maximum(span, 1e-3 * np.abs(fine).max(axis=0) + 1e-300)
    errors = 4.0 / 3.0 * np.abs(coarse - fine).max(axis=0) / scale
    errors = np.nan_to_num(errors, nan=0.0)
    k = int(np.argmax(errors))
    return float(errors[k]), k


def _cache_path(spec: ManipulatorSpec, stable: float) -> Path:
    from maniplab_native.build import cache_root

    digest = hashlib.sha256()
    spec_data = spec.to_dict()
    spec_data.pop("control", None)
    spec_data.pop("name", None)
    digest.update(json.dumps(spec_data, sort_keys=True).encode())
    digest.update(repr((stable, TOLERANCE, SAFETY, DURATION, SWITCH, AMPLITUDE)).encode())
    digest.update(_sources_digest().encode())
    return cache_root() / "steps" / f"{digest.hexdigest()[:32]}.json"


@functools.lru_cache(maxsize=1)
def _sources_digest() -> str:
    """SHA-256 of the sources that build and integrate the model: the C plugins, this package
    and the actuators."""
    from maniplab_native.build import sources

    digest = hashlib.sha256()
    here = Path(__file__).resolve().parent
    for source in [*sources(), *sorted(here.glob("*.py")),
                   *sorted((here.parent / "actuators").rglob("*.py"))]:
        digest.update(source.name.encode() + b"\0" + source.read_bytes())
    return digest.hexdigest()
