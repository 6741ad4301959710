"""Cost of a controller written in Python, per call, against the compiled cascade in one run.

On crane3's move (3 s, 3.5 s simulated), the same run under:

- the compiled cascade (no Python per sample: the C loop calls its C function);
- the cascade called from Python (a plain function wrapping it: the C loop calls back into
  Python at each sample, then the cascade's sample);
- a Python controller that returns a constant command (the call-back overhead alone:
  ``PlantState`` built, the call, the command converted);
- an ``ml.Controller`` subclass doing the same (the interface's ``__call__`` and ``log``);

each at 500 Hz. Prints medians of REPEAT runs (CPU time), and the Python work of one call as the
run loop does it (the plant's state read, the controller called, its command converted) timed
directly. Not part of the tests.

    python benchmarks/bench_controller.py
"""

from __future__ import annotations

import statistics
import time
from typing import Any

import numpy as np

import maniplab as ml
from maniplab.sim.plant import Plant
from maniplab.sim.simulate import _call

REPEAT = 7
RATE = 500.0


class Constant(ml.Controller):
    """An interface controller that logs one signal and returns a constant command."""

    dt = 1.0 / RATE
    log_signals = {"x": ("a logged value", "1")}  # noqa: RUF012

    def __init__(self, u: np.ndarray) -> None:
        self.u = u

    def output(self, t: float, state: Any) -> np.ndarray:
        self.log(x=t)
        return self.u


def cpu(run: Any) -> float:
    start = time.process_time()
    run()
    return time.process_time() - start


def per_call_us(plant: Plant, controller: Any, calls: int = 2000) -> float:
    """Median over REPEAT of the µs of one call as the run loop makes it (``simulate._call``)."""
    samples = []
    for _ in range(REPEAT):
        start = time.perf_counter()
        for k in range(calls):
            _call(controller, 0.5 + k / RATE, plant)
        samples.append((time.perf_counter() - start) / calls * 1e6)
    return statistics.median(samples)


def main() -> None:
    spec = ml.builtin_spec("crane3")
    plan = ml.control.plan_move(spec, [5.46, 0.6, 1.4], start=[0.0, 0.0, 0.5], duration=3.0)
    cascade = ml.CascadeController(spec, plan.move, rate=RATE)
    kw = {"duration": 3.5, "initial": {"q": plan.q_start, "dP": "gravity"}}
    u = np.zeros(spec.n)

    def plain(t: float, state: Any) -> np.ndarray:
        return cascade(t, state)

    def constant(t: float, state: Any) -> np.ndarray:
        return u

    constant.dt = plain.dt = 1.0 / RATE  # type: ignore[attr-defined]
    cases = {
        "compiled cascade": lambda: ml.simulate(spec, controller=cascade, **kw),
        "cascade called from Python": lambda: ml.simulate(spec, controller=plain, **kw),
        "Python function, constant": lambda: ml.simulate(spec, controller=constant, **kw),
        "ml.Controller subclass, constant + log": lambda: ml.simulate(
            spec, controller=Constant(u), **kw),
    }
    times = {name: statistics.median(cpu(run) for _ in range(REPEAT))
             for name, run in cases.items()}
    plant = Plant(spec)
    plant.set_state(q=plan.q_start)
    per_call = {name: per_call_us(plant, controller) for name, controller in (
        ("cascade called from Python", plain), ("Python function, constant", constant),
        ("ml.Controller subclass, constant + log", Constant(u)))}
    calls = kw["duration"] * RATE
    base = times["compiled cascade"]
    print(f"crane3, {kw['duration']} s simulated, controller at {RATE:g} Hz ({calls:.0f} calls), "
          f"medians of {REPEAT} (CPU)")
    print("| what | CPU [s] | × real time | run - compiled run [ms] | one call's Python [µs] |")
    print("|---|---|---|---|---|")
    for name, t in times.items():
        one = f"{per_call[name]:.1f}" if name in per_call else "-"
        print(f"| {name} | {t:.3f} | {kw['duration'] / t:.0f} | {1e3 * (t - base):+.1f} | {one} |")


if __name__ == "__main__":
    main()
