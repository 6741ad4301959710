"""Speed of the closed loop on the erector: real-time factor, and the controller against the plant.

Runs the acceptance move (1 m in 4 s, 5.5 s simulated) under the cascade controller through
``ml.simulate``, several times, and in the same process the plant alone for the same time with
the controller's recorded commands replayed as input signals. Prints medians:

- the closed-loop run's wall time and real-time factor (target: >= 10x faster than real time);
- the plant alone (same steps, same commands);
- the controller's share = closed loop - plant alone, and per controller sample (µs), which
  must stay below the plant's cost;
- one controller sample timed directly on recorded states.

Not part of the test suite (timings depend on the machine and its load; the ratios measured in
one run are the figures to compare).

    python benchmarks/bench_control.py
"""

from __future__ import annotations

import statistics
import sys
import timeit
from pathlib import Path

import numpy as np

import maniplab as ml
from maniplab.control.kinematics import inverse_kinematics

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
from _validation import MOVE_Q0, acceptance_move  # noqa: E402

REPEAT = 5


def closed_loop(spec: ml.ManipulatorSpec, model: ml.AnalyticModel, move: ml.MinJerkMove,
                q0: np.ndarray, duration: float) -> tuple[float, ml.Run, ml.CascadeController]:
    controller = ml.CascadeController(spec, move, task="position", model=model)
    start = timeit.default_timer()
    run = ml.simulate(spec, controller=controller, duration=duration,
                      initial={"q": q0, "dP": "gravity"})
    return timeit.default_timer() - start, run, controller


def plant_alone(spec: ml.ManipulatorSpec, run: ml.Run, q0: np.ndarray, duration: float) -> float:
    """The same run with the recorded commands replayed (piecewise constant) as input signals."""
    t, ctrl = np.asarray(run.t), np.asarray(run["ctrl"])

    def replay(j: int):  # noqa: ANN202
        column = ctrl[:, j]
        return lambda tk: float(column[min(int(np.searchsorted(t, tk + 1e-12) - 1), len(t) - 1)])

    inputs = {name: replay(j) for j, name in enumerate(spec.joint_names)}
    start = timeit.default_timer()
    ml.simulate(spec, inputs=inputs, duration=duration, initial={"q": q0, "dP": "gravity"})
    return timeit.default_timer() - start


def plant_idle(spec: ml.ManipulatorSpec, q0: np.ndarray, duration: float) -> float:
    """The plant alone with zero commands (no per-step input callables)."""
    start = timeit.default_timer()
    ml.simulate(spec, duration=duration, initial={"q": q0, "dP": "gravity"})
    return timeit.default_timer() - start


def main() -> int:
    spec = ml.builtin_spec("erector")
    model = ml.AnalyticModel(spec)
    move = acceptance_move(model)
    q0 = inverse_kinematics(model, move.start, MOVE_Q0, task="position")
    duration = move.t0 + move.duration + 1.0
    closed_loop(spec, model, move, q0, 0.5)  # warm up
    loops, plants, idles = [], [], []
    for _ in range(REPEAT):
        wall, run, controller = closed_loop(spec, model, move, q0, duration)
        loops.append(wall)
        plants.append(plant_alone(spec, run, q0, duration))
        idles.append(plant_idle(spec, q0, duration))
    samples = len(controller.times)
    steps = round(duration / run.meta["dt"])
    t_loop, t_plant, t_idle = (statistics.median(x) for x in (loops, plants, idles))
    # one controller sample on recorded states, timed directly
    states = [(float(tk), np.asarray(run.q[k]), np.asarray(run.qd[k]), np.asarray(run["dP"][k]))
              for k, tk in enumerate(run.t[:: max(1, len(run.t) // 500)])]
    bench = ml.CascadeController(spec, move, task="position", model=model)
    per_sample = statistics.median(timeit.repeat(
        lambda: [bench.step(*s) for s in states], number=1, repeat=7)) / len(states) * 1e6
    controller_share = max(t_loop - t_idle, 0.0)
    rows = [
        ("closed loop, wall time", f"{t_loop:.3f} s", f"{duration / t_loop:.1f}x real time "
         f"({duration:g} s simulated, {steps} plant steps, {samples} controller samples)"),
        ("plant alone, zero commands", f"{t_idle:.3f} s", f"{duration / t_idle:.1f}x real time"),
        ("plant alone, commands replayed", f"{t_plant:.3f} s",
         "input signals are Python callables, called every step"),
        ("controller share (loop - plant)", f"{controller_share:.3f} s",
         f"{controller_share / t_idle:.2f}x the plant"),
        ("controller sample, timed directly", f"{per_sample:.1f} µs",
         f"x {samples} samples = {per_sample * samples * 1e-6:.3f} s; plant step "
         f"{t_idle / steps * 1e6:.1f} µs"),
    ]
    width = max(len(r[0]) for r in rows)
    print(f"erector, {spec.n} joints, controller at {controller.rate:g} Hz, plant dt "
          f"{run.meta['dt']:g} s ({run.meta['integrator']}), medians of {REPEAT}\n")
    print(f"| {'what'.ljust(width)} | time | note |\n|{'-' * (width + 2)}|---|---|")
    for what, value, note in rows:
        print(f"| {what.ljust(width)} | {value} | {note} |")
    ok = duration / t_loop >= 10.0 and controller_share < t_idle
    print(f"\nclosed loop >= 10x real time: {duration / t_loop >= 10.0}; "
          f"controller cheaper than the plant: {controller_share < t_idle}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
