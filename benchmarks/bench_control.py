"""Speed of the closed loop on the erector: real-time factor, and the controller against the plant.

Runs the acceptance move (1 m in 4 s, 5.5 s simulated) under the cascade controller through
``ml.simulate``, several times, and in the same process the plant alone. Prints medians:

- the closed-loop run's time and real-time factor (target: >= 10x faster than real time);
- the plant alone: the same run with the recorded commands replayed by a trivial controller
  at the same rate (same motion, same per-call overhead of simulate), and at rest;
- the controller's share = closed loop - replay, and per controller sample (µs), which must
  stay below the plant's cost;
- one controller sample timed directly on recorded states.

CPU time (``time.process_time``) is the steadier figure on a shared machine; wall time is shown
too. Not part of the test suite (timings depend on the machine and its load; the ratios
measured in one run are the figures to compare).

    python benchmarks/bench_control.py
"""

from __future__ import annotations

import statistics
import sys
import time
import timeit
from pathlib import Path

import numpy as np
from typing_extensions import Self

import maniplab as ml
from maniplab.control.ik import inverse_kinematics

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
from _validation import MOVE_Q0, acceptance_move

REPEAT = 5


class Clock:
    """CPU and wall time of a block: ``with Clock() as c: ...; c.cpu, c.wall`` (s)."""

    def __enter__(self) -> Self:
        self._cpu, self._wall = time.process_time(), time.perf_counter()
        return self

    def __exit__(self, *exc: object) -> None:
        self.cpu = time.process_time() - self._cpu
        self.wall = time.perf_counter() - self._wall


def closed_loop(spec: ml.ManipulatorSpec, model: ml.AnalyticModel, move: ml.MinJerkMove,
                q0: np.ndarray, duration: float) -> tuple[Clock, ml.Run, ml.CascadeController]:
    controller = ml.CascadeController(spec, move, task="position", model=model)
    with Clock() as clock:
        run = ml.simulate(spec, controller=controller, duration=duration,
                          initial={"q": q0, "dP": "gravity"})
    return clock, run, controller


class Replay:
    """A controller that replays recorded commands: the plant's motion at almost no cost."""

    def __init__(self, controller: ml.CascadeController) -> None:
        self.dt = controller.dt
        self.commands = [np.asarray(c) for c in controller.signals()["cmd"]]
        self.k = 0

    def __call__(self, t: float, state: object) -> np.ndarray:
        command = self.commands[min(self.k, len(self.commands) - 1)]
        self.k += 1
        return command


def plant_alone(spec: ml.ManipulatorSpec, controller: ml.CascadeController, q0: np.ndarray,
                duration: float) -> Clock:
    """The same run with the controller's commands replayed at its rate: the same plant motion
    and the same per-call overhead of simulate, without the control law."""
    replay = Replay(controller)
    with Clock() as clock:
        ml.simulate(spec, controller=replay, duration=duration,
                    initial={"q": q0, "dP": "gravity"})
    return clock


def plant_idle(spec: ml.ManipulatorSpec, q0: np.ndarray, duration: float) -> Clock:
    """The plant alone with zero commands (no per-step input callables)."""
    with Clock() as clock:
        ml.simulate(spec, duration=duration, initial={"q": q0, "dP": "gravity"})
    return clock


def main() -> int:
    spec = ml.builtin_spec("erector")
    model = ml.AnalyticModel(spec)
    move = acceptance_move(model)
    q0 = inverse_kinematics(model, move.start, MOVE_Q0, task="position")
    duration = move.t0 + move.duration + 1.0
    closed_loop(spec, model, move, q0, 0.5)  # warm up
    loops, plants, idles = [], [], []
    for _ in range(REPEAT):
        clock, run, controller = closed_loop(spec, model, move, q0, duration)
        loops.append(clock)
        plants.append(plant_alone(spec, controller, q0, duration))
        idles.append(plant_idle(spec, q0, duration))
    samples = len(controller.times)
    steps = round(duration / run.meta["dt"])
    med = lambda clocks, kind: statistics.median(getattr(c, kind) for c in clocks)
    # one controller sample on recorded states, timed directly
    states = [(float(tk), np.asarray(run.q[k]), np.asarray(run.qd[k]), np.asarray(run["dP"][k]))
              for k, tk in enumerate(run.t[:: max(1, len(run.t) // 500)])]
    bench = ml.CascadeController(spec, move, task="position", model=model)
    per_sample = statistics.median(timeit.repeat(
        lambda: [bench.step(t, q, qd, dP=dP) for t, q, qd, dP in states], number=1,
        repeat=7)) / len(states) * 1e6
    rows = []
    for kind in ("cpu", "wall"):
        loop, idle, replay = med(loops, kind), med(idles, kind), med(plants, kind)
        share = max(loop - replay, 0.0)
        rows += [
            (f"closed loop ({kind})", f"{loop:.3f} s", f"{duration / loop:.1f}x real time"),
            (f"plant, commands replayed ({kind})", f"{replay:.3f} s",
             f"{duration / replay:.1f}x real time; {replay / steps * 1e6:.1f} µs per step"),
            (f"plant at rest, zero commands ({kind})", f"{idle:.3f} s",
             f"{duration / idle:.1f}x real time (stuck joints are cheaper)"),
            (f"controller, loop - replay ({kind})", f"{share:.3f} s",
             f"{share / replay:.2f}x the plant; {share / samples * 1e6:.1f} µs per sample"),
        ]
    rows.append(("controller sample, timed directly (wall)", f"{per_sample:.1f} µs",
                 f"x {samples} samples = {per_sample * samples * 1e-6:.3f} s"))
    width = max(len(r[0]) for r in rows)
    print(f"erector, {spec.n} joints, {duration:g} s simulated: {steps} plant steps (dt "
          f"{run.meta['dt']:g} s, {run.meta['integrator']}), {samples} controller samples "
          f"({controller.rate:g} Hz); medians of {REPEAT}\n")
    print(f"| {'what'.ljust(width)} | time | note |\n|{'-' * (width + 2)}|---|---|")
    for what, value, note in rows:
        print(f"| {what.ljust(width)} | {value} | {note} |")
    cpu_loop, cpu_plant = med(loops, "cpu"), med(plants, "cpu")
    fast = duration / cpu_loop >= 10.0
    cheap = cpu_loop - cpu_plant < cpu_plant
    print(f"\nclosed loop >= 10x real time (CPU): {fast}; controller cheaper than the plant "
          f"(CPU): {cheap}")
    return 0 if fast and cheap else 1


if __name__ == "__main__":
    sys.exit(main())
