"""Sweep speed-up: 8 erector variants on 2 workers versus 1 (issue target: >= 1.7x).

Run: .venv/bin/python benchmarks/bench_sweep.py [--repeats 3] [--duration 10]
Prints the median wall times and their ratios, measured in one run (the machine is shared and
noisy, so only the ratios are meaningful). Three ways, all through ``ml.sweep``:

- 1 worker: ``processes=1``, the variants one after another in the calling process;
- 2 threads: ``processes=2``, the default for the erector (no variant needs Python while it
  steps, so the plant in C runs them in threads of this process, GIL released);
- 2 processes: a ``ProcessPoolExecutor(2)`` given as ``executor`` (what a sweep whose variants
  need Python per step, a controller or a Python actuator, gets by default); pool start-up
  included.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import statistics
import tempfile
import time
from typing import Any

import maniplab as ml

GRID = {"end_effector.mass": [3000.0, 3500.0, 4000.0, 5000.0],
        "joints.q2.actuator.leakage": [1e-12, 1e-11]}


def wall_time(how: str, duration: float) -> float:
    """Seconds to sweep the 8 variants ``how`` ("1", "threads", "processes")."""
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        args: dict[str, Any] = {"processes": 1} if how == "1" else {"processes": 2}
        pool = cf.ProcessPoolExecutor(2) if how == "processes" else None
        if pool is not None:
            args = {"executor": pool}
        try:
            runs = ml.sweep("erector", GRID, out=out, duration=duration,
                            inputs={"q2": ml.signals.step(0.2, t0=0.1)},
                            initial={"dP": "gravity"}, progress=False, **args)
        finally:
            if pool is not None:
                pool.shutdown()
        elapsed = time.perf_counter() - start
    assert len(runs) == 8 and not runs.failures
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--duration", type=float, default=10.0, help="simulated s per variant")
    args = parser.parse_args()
    ways = {"1": "1 worker (in the caller)", "threads": "2 threads (default)",
            "processes": "2 processes"}
    times: dict[str, list[float]] = {how: [] for how in ways}
    for _ in range(args.repeats):  # interleaved, so drifts of the machine hit all alike
        for how in ways:
            times[how].append(wall_time(how, args.duration))
    medians = {how: statistics.median(t) for how, t in times.items()}
    one = medians["1"]
    print(f"8 erector variants x {args.duration:g} s simulated, median of {args.repeats}:\n")
    print("| workers | wall time | speed-up |")
    print("|---|---|---|")
    for how, name in ways.items():
        print(f"| {name} | {medians[how]:.2f} s | {one / medians[how]:.2f}x |")
    print("\n(target: >= 1.7x on two cores)")


if __name__ == "__main__":
    main()
