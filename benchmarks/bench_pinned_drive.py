"""The pinned cylinders' drive compiled into the cascade (issue 36): a closed-loop move of patu655
and of the knuckle crane (tests/arms), the drive in C against the same drive in Python (its
``compiled()`` switched off, as before), in one run; medians of REPEAT runs, CPU time.

    python benchmarks/bench_pinned_drive.py
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np

import maniplab as ml
from maniplab.actuators.hydraulic.pinned_drive import ChamberDrive
from maniplab.control.cascade import CascadeController
from maniplab.control.point_to_point import plan_move

REPEAT = 5
ARMS = Path(__file__).resolve().parents[1] / "tests" / "arms"
CASES = {
    "patu655": ("patu655", [0.0, -0.3, 1.2], [0.4, -0.5, 0.9], 5.0),
    "knuckle crane": (str(ARMS / "knuckle_crane.yaml"), [-1.29, -0.44, 1.48, 0.77, 0.0],
                      [-0.9, -0.5, 1.2, 0.9, 0.0], 5.0),
}


def cpu_of_run(spec: ml.ManipulatorSpec, plan, model) -> tuple[float, float]:
    controller = CascadeController(spec, plan.move, task=plan.task, model=model)
    duration = plan.move.t0 + plan.move.duration + 1.0
    times = []
    for _ in range(REPEAT):
        start = time.process_time()
        ml.simulate(spec, controller=controller, duration=duration,
                    initial={"q": plan.q_start, "dP": "gravity"})
        times.append(time.process_time() - start)
    return statistics.median(times), duration


def main() -> None:
    compiled = ChamberDrive.compiled
    print(f"closed-loop moves, medians of {REPEAT} (CPU)")
    print("| arm | move [s] | drive in C: CPU [s], × real time | drive in Python | speed-up |")
    print("|---|---|---|---|---|")
    for name, (source, start, goal, duration) in CASES.items():
        spec = ml.resolve_spec(source)
        model = ml.AnalyticModel(spec)
        target = model.fk(np.array(goal))[:3, 3]
        plan = plan_move(spec, target, start=start, duration=duration, model=model)
        fast, simulated = cpu_of_run(spec, plan, model)
        ChamberDrive.compiled = lambda self: None  # type: ignore[method-assign,assignment,return-value]
        try:
            slow, _ = cpu_of_run(spec, plan, model)
        finally:
            ChamberDrive.compiled = compiled  # type: ignore[method-assign]
        print(f"| {name} | {plan.move.duration:.2f} | {fast:.3f}, {simulated / fast:.0f}× | "
              f"{slow:.3f}, {simulated / slow:.0f}× | {slow / fast:.1f}× |")


if __name__ == "__main__":
    main()
