"""The hydraulic states at the mechanics' step (issue 36): for each arm, open loop (every valve a
held sine) and under the cascade (a move), the run at the derived step against

- the same run at a hundredth of that step (the accuracy: the worst signal's largest deviation
  relative to its range; stick/slip friction left out, its viscous part kept, as the derivation
  does: where a joint sticks is an event located to the step), and
- the same run at the step the arm was derived before (the stability limit of the chambers'
  filling and the spool's lag under RK4: ``rates``/``decays`` without the engine plugin's exact
  step): the speed-up, and each run's speed in real time;

medians of REPEAT runs of CPU time, in one process. The closed-loop run is timed from the
controller's construction to the run's end; planning the move (inverse kinematics along the path
and the actuators' demand, done once per move) is timed apart.

    python benchmarks/bench_stiff_step.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
import warnings
from pathlib import Path

import numpy as np

import maniplab as ml
from maniplab.control.cascade import CascadeController
from maniplab.control.point_to_point import MovePlan, plan_move
from maniplab.mjcf_gen import accuracy, build_model
from maniplab.mjcf_gen.accuracy import StepWarning
from maniplab.mjcf_gen.timestep import (
    OSCILLATION,
    RATE,
    STABLE,
    StepLimit,
    default_step,
    spring_modes,
)
from maniplab.spec import model_of

ARMS = Path(__file__).resolve().parents[1] / "tests" / "arms"
CASES = {  # name: (spec, start, move target as a joint pose, move duration s)
    "patu655": ("patu655", [0.0, -0.3, 1.2], [0.4, -0.5, 0.9], 5.0),
    "excavator": ("excavator", [0.0, -0.3, 1.2, 0.5], [0.5, -0.5, 1.5, 0.8], 8.0),
    "erector_pinned": ("erector_pinned", [-0.18, 1.27, 0.0, 0.0, 0.0, 0.0],
                       [-0.6, 1.0, 0.3, 0.1, 0.05, -0.05], 4.0),
    "knuckle crane": (str(ARMS / "knuckle_crane.yaml"), None, None, 5.0),
}
OPEN_LOOP = 5.0
"""s of the open-loop run timed."""
ACCURACY_WINDOW = 1.0
"""s of each run compared with its 1/100 reference."""


def old_step(spec: ml.ManipulatorSpec) -> float:
    """The step derived before: RK4's stability on every actuator rate and decay, and the
    spring modes."""
    best = math.inf
    for actuator in (model_of(j) for j in spec.joints):
        for rate in actuator.rates(False).values():
            best = min(best, RATE / rate) if rate > 0 else best
        for rate in actuator.decays(False).values():
            best = min(best, STABLE / rate) if rate > 0 else best
    fastest = spring_modes(spec, build_model(spec)).fastest
    if fastest > 0:
        best = min(best, OSCILLATION / fastest)
    return default_step(StepLimit(best))


def held_sines(limits: np.ndarray, dt: float, duration: float) -> dict[int, object]:
    t = np.arange(0.0, duration + dt, dt)
    return {j: ml.signals.held(t, 0.6 * float(a) * np.sin(2.0 * np.pi * (0.4 + 0.3 * j) * t))
            for j, a in enumerate(limits)}


def open_loop(spec: ml.ManipulatorSpec, dt: float, hold: float, duration: float) -> ml.Run:
    start = np.array([0.5 * sum(j.limits) if j.limits else 0.0 for j in spec.joints])
    plant = ml.Plant(spec, dt=dt)
    return ml.simulate(plant, inputs=held_sines(plant.command_limit, hold, duration),
                       duration=duration, initial={"q": start, "dP": "gravity"},
                       sample_dt=hold)


def planned(spec: ml.ManipulatorSpec, case: tuple) -> MovePlan:
    """The case's move, planned (inverse kinematics along the path, the actuators' demand)."""
    _, start, goal, duration = case
    lo = np.array([j.limits[0] for j in spec.joints])
    hi = np.array([j.limits[1] for j in spec.joints])
    start = np.asarray(start) if start is not None else 0.5 * (lo + hi)
    goal = np.asarray(goal) if goal is not None else start + 0.05 * (hi - lo)
    target = ml.AnalyticModel(spec).fk(goal)[:3, 3]
    return plan_move(spec, target, start=start, duration=duration)


def closed_loop(spec: ml.ManipulatorSpec, plan: MovePlan, dt: float, settle: float) -> ml.Run:
    """The planned move under the cascade (as ``run_move`` runs it, the plan made already)."""
    controller = CascadeController(spec, plan.move, task=plan.task,
                                   joint_path=plan.joint_reference)
    return ml.simulate(ml.Plant(spec, dt=dt), controller=controller,
                       duration=plan.move.t0 + plan.move.duration + settle,
                       initial={"q": plan.q_start, "dP": "gravity"}, sample_dt=5e-3)


def deviation(a: ml.Run, b: ml.Run, names: list[str]) -> tuple[float, str]:
    worst = (0.0, "")
    for name in names:
        x, y = np.asarray(a[name]), np.asarray(b[name])
        count = min(len(x), len(y))
        x, y = x[:count], y[:count]
        has = ~np.isnan(y).all(axis=0)
        if not has.any():
            continue
        span = np.maximum(np.ptp(y[:, has], axis=0), 1e-12)
        e = float(np.max(np.abs(x[:, has] - y[:, has]).max(axis=0) / span))
        worst = max(worst, (e, name))
    return worst


def cpu(repeat: int, fn, *args) -> float:
    """The median CPU time of ``fn(*args)`` over ``repeat`` calls, s."""
    times = []
    for _ in range(repeat):
        start = time.process_time()
        fn(*args)
        times.append(time.process_time() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    warnings.simplefilter("ignore", StepWarning)
    print("| arm | derived step (before) | open loop: × real time (before), speed-up | "
          "deviation from 1/100, open loop | closed loop: × real time (before), speed-up | "
          "deviation from 1/100, closed loop | planning the move |")
    print("|---|---|---|---|---|---|---|")
    for name, case in CASES.items():
        spec = accuracy.smooth(ml.resolve_spec(case[0]))
        plant = ml.Plant(spec)
        dt, before = plant.dt, old_step(spec)
        names = ["q", "qd", *plant.state_names]
        coarse = open_loop(spec, dt, dt, ACCURACY_WINDOW)
        fine = open_loop(spec, dt / 100.0, dt, ACCURACY_WINDOW)
        error, signal = deviation(coarse, fine, names)
        hold = max(dt, before)
        new_open = cpu(args.repeat, open_loop, spec, dt, hold, OPEN_LOOP)
        old_open = cpu(args.repeat, open_loop, spec, before, hold, OPEN_LOOP)
        planning = cpu(args.repeat, planned, spec, case)
        plan = planned(spec, case)
        new_closed = cpu(args.repeat, closed_loop, spec, plan, dt, 1.0)
        old_closed = cpu(args.repeat, closed_loop, spec, plan, before, 1.0)
        closed = deviation(closed_loop(spec, plan, dt, 0.0),
                           closed_loop(spec, plan, dt / 100, 0.0), names)
        length = plan.move.t0 + plan.move.duration + 1.0
        print(f"| {name} | {dt * 1e3:g} ms ({before * 1e3:g} ms) | {OPEN_LOOP / new_open:.0f}× "
              f"({OPEN_LOOP / old_open:.0f}×), {old_open / new_open:.1f}× | {error:.1e} "
              f"({signal}) | {length / new_closed:.0f}× ({length / old_closed:.0f}×), "
              f"{old_closed / new_closed:.1f}× | {closed[0]:.1e} ({closed[1]}) | "
              f"{planning * 1e3:.0f} ms |", flush=True)


if __name__ == "__main__":
    main()
