"""Optimisation throughput: candidates evaluated per minute, on 1 and 2 worker processes.

Run: .venv/bin/python benchmarks/bench_optimize.py [--budget 32]
Two studies, each from an empty results folder (no evaluation cached), the wall time of
``ml.optimize`` (pool start-up, the baseline's and the sensitivity's evaluations included, the
report not written), after a warm-up study of 2 candidates in this process (imports):

- statics: the forestry crane's lift and tilt bores (ISO 3320) and pins against the smallest
  payload of its load chart (9 points per joint), NSGA-II;
- co-design: the docs' study (examples/optimize/forestry_codesign.yaml): pins, bores, valves and
  the controller's rate, a duty cycle of two closed-loop moves per candidate, NSGA-II.

Prints a Markdown table of candidates per minute (computed evaluations / wall time) and the
speed-up of 2 processes over 1 (the machine is shared and noisy: the ratio is the figure to
compare).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml

import maniplab as ml

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "optimize"


def studies(budget: int) -> dict[str, dict[str, Any]]:
    codesign = yaml.safe_load((EXAMPLES / "forestry_codesign.yaml").read_text())
    codesign.update(spec=str(EXAMPLES / codesign["spec"]), budget=budget, population=8)
    statics = {
        "spec": str(EXAMPLES / "forestry_crane.yaml"), "seed": 1, "budget": budget,
        "population": 8, "statics": {"points": 9},
        "variables": codesign["variables"][:4],
        "objectives": [{"metric": "payload_min", "sense": "max"},
                       {"metric": "param:joints.lift.actuator.cylinder.bore", "sense": "min"}]}
    return {"statics (load chart)": statics, "co-design (duty cycle of 2 moves)": codesign}


def rate(study: dict[str, Any], processes: int) -> tuple[float, int, float]:
    """(candidates per minute, evaluations computed, wall time s)."""
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        result = ml.optimize(study, out=out, processes=processes, report=False)
        wall = time.perf_counter() - start
    return 60.0 * result.computed / wall, result.computed, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=int, default=32, help="candidates per study")
    args = parser.parse_args()
    print("| study | processes | evaluations | wall time | candidates/min | speed-up |")
    print("|---|---|---|---|---|---|")
    for name, study in studies(args.budget).items():
        rate({**study, "budget": 2}, 1)  # imports and first builds, outside the timing
        one = None
        for processes in (1, 2):
            per_minute, computed, wall = rate(study, processes)
            one = one or per_minute
            print(f"| {name} | {processes} | {computed} | {wall:.1f} s | {per_minute:.0f} | "
                  f"{per_minute / one:.2f}x |", flush=True)


if __name__ == "__main__":
    main()
