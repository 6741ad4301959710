"""Sweep speed-up: 8 erector variants on 2 local processes versus 1 (issue target: >= 1.7x).

Run: .venv/bin/python benchmarks/bench_sweep.py [--repeats 3] [--duration 10]
Prints the median wall times and their ratio, measured in one run (the machine is shared and
noisy, so only the ratio is meaningful).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time

import maniplab as ml

GRID = {"end_effector.mass": [3000.0, 3500.0, 4000.0, 5000.0],
        "joints.q2.actuator.leakage": [1e-12, 1e-11]}


def wall_time(processes: int, duration: float) -> float:
    """Seconds to sweep the 8 variants with ``processes`` workers (pool start-up included)."""
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        runs = ml.sweep("erector", GRID, out=out, duration=duration, processes=processes,
                        inputs={"q2": ml.signals.step(0.2, t0=0.1)}, initial={"dP": "gravity"},
                        progress=False)
        elapsed = time.perf_counter() - start
    assert len(runs) == 8 and not runs.failures
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--duration", type=float, default=10.0, help="simulated s per variant")
    args = parser.parse_args()
    one, two = [], []
    for _ in range(args.repeats):  # interleaved, so drifts of the machine hit both alike
        one.append(wall_time(1, args.duration))
        two.append(wall_time(2, args.duration))
    t1, t2 = statistics.median(one), statistics.median(two)
    print(f"8 erector variants x {args.duration:g} s simulated, median of {args.repeats}:")
    print(f"  1 process : {t1:6.2f} s")
    print(f"  2 processes: {t2:6.2f} s")
    print(f"  speed-up  : {t1 / t2:.2f}x (target >= 1.7x)")


if __name__ == "__main__":
    main()
