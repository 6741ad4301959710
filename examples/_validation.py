"""Shared set-up of the controller validation scripts (not a script itself).

The erector's validation cases, how a case is run (``ml.simulate`` with the controller, its log
added to the Run) and how the results are reported (table on stdout, Markdown and JSON tables,
comparison plot, the runs as .npz).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

import maniplab as ml
from maniplab.control.kinematics import inverse_kinematics
from maniplab.control.metrics import TrackingMetrics, format_table, to_json, tracking_metrics
from maniplab.control.plots import save_figure, tracking_figure
from maniplab.specfile import write_atomic

#: The acceptance move: from this pose of the erector (rad, m) ...
MOVE_Q0 = np.array([-0.18, 1.27, 0.0, 0.0, 0.0, 0.0])
#: ... 1 m along this direction (base axes; in the plane of the lifting joints) in 4 s.
MOVE_DIRECTION = np.array([-0.892, 0.453, 0.0]) / np.linalg.norm([-0.892, 0.453, 0.0])
MOVE_LENGTH, MOVE_TIME = 1.0, 4.0
#: Segment placement: the segment on the feeder, arm pose (rad, m).
PICK_Q0 = np.array([-0.9, 1.3, -0.4, -0.1, 0.0, 0.0])
START = 0.5  # s at rest before the reference starts to move


def parse_args(description: str, argv: Sequence[str] | None, *,
               tune: bool = False) -> argparse.Namespace:
    """The scripts' options: -o DIR, --short (and --tune where ``tune``)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("-o", "--output", type=Path, default=Path("out/examples"),
                        help="folder for the table, plots and runs (default out/examples)")
    parser.add_argument("--short", action="store_true",
                        help="a short version (smaller, quicker moves) for the test suite")
    if tune:
        parser.add_argument("--tune", action="store_true",
                            help="redo the grid search of the baseline's gains first")
    return parser.parse_args(argv)


def acceptance_move(model: ml.AnalyticModel, *, short: bool = False) -> ml.MinJerkMove:
    """The 1 m Cartesian move in 4 s (short: 0.25 m in 1.5 s), starting at t = START."""
    start = ml.Pose.from_matrix(model.fk(MOVE_Q0))
    length, time = (0.25, 1.5) if short else (MOVE_LENGTH, MOVE_TIME)
    return ml.MinJerkMove(start, start.translated(length * MOVE_DIRECTION), time, t0=START)


def placement_path(model: ml.AnalyticModel, *, short: bool = False) -> ml.Path:
    """The segment placement manoeuvre: lift 0.3 m, turn 0.25 rad about the tunnel axis, push
    0.2 m home (short: 0.1 m, 0.08 rad, 0.08 m, quicker), starting at t = START."""
    pick = ml.Pose.from_matrix(model.fk(PICK_Q0))
    if short:
        return ml.segment_placement(pick, lift=0.1, ring_angle=0.08, push=0.08,
                                    durations=(1.0, 1.5, 1.0), dwell=0.2, t0=START)
    return ml.segment_placement(pick, lift=0.3, ring_angle=0.25, push=0.2,
                                durations=(3.0, 5.0, 2.5), dwell=0.5, t0=START)


def run_case(spec: ml.ManipulatorSpec, trajectory: Any, q_seed: np.ndarray, *, label: str,
             mode: str = "cascade", payload_factor: float = 1.0, settle: float = 1.0,
             model: ml.AnalyticModel | None = None, **settings: Any) -> tuple[ml.Run, TrackingMetrics]:
    """Simulate ``spec`` under the controller following ``trajectory``; returns the run and metrics.

    The plant starts at rest on the reference's first pose (inverse kinematics from q_seed),
    its pressures holding it against gravity. The controller's model has the payload mass
    times ``payload_factor`` (its estimate); the plant has the spec's.
    """
    model = model or ml.AnalyticModel(spec)
    task = settings.get("task") or (spec.control.task if spec.control else None) or (
        "pose" if spec.n >= 6 else "position")
    q0 = inverse_kinematics(model, trajectory.start, q_seed, task=task)
    believed = spec
    if payload_factor != 1.0:
        believed = spec.with_overrides({"end_effector.mass": spec.end_effector.mass * payload_factor})
    controller = ml.CascadeController(believed, trajectory, mode=mode, **settings)
    duration = trajectory.t0 + trajectory.duration + settle
    run = ml.simulate(spec, controller=controller, duration=duration,
                      initial={"q": q0, "dP": "gravity"}, label=label)
    run = controller.annotate(run)
    return run, tracking_metrics(run, trajectory, label=label, model=model)


def report(name: str, title: str, cases: Sequence[tuple[ml.Run, TrackingMetrics]],
           trajectory: Any, output: Path) -> None:
    """Print the table and write ``<name>.md``, ``<name>.json``, ``<name>.png`` and the runs."""
    rows = [m for _, m in cases]
    table = format_table(rows)
    print(f"\n{title}\n\n{table}\n", flush=True)
    output.mkdir(parents=True, exist_ok=True)
    write_atomic(output / f"{name}.md", f"# {title}\n\n{table}\n")
    write_atomic(output / f"{name}.json", to_json(rows) + "\n")
    fig = tracking_figure([r for r, _ in cases], trajectory, title=title)
    save_figure(fig, output / f"{name}.png")
    for run, metrics in cases:
        run.save(output / f"{name}-{_slug(metrics.label)}.npz")
    print(f"wrote {output / (name + '.md')}, .json, .png and {len(cases)} runs", flush=True)


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in text.lower()).strip("-")


def ratio_line(numerator: TrackingMetrics, denominator: TrackingMetrics) -> str:
    """'RMS error ratio' sentence for the log."""
    return (f"RMS error, {numerator.label} / {denominator.label}: "
            f"{numerator.rms_error_mm / denominator.rms_error_mm:.1f}x")


def dump_json(path: Path, data: Any) -> None:
    write_atomic(path, json.dumps(data, indent=2) + "\n")


if __name__ == "__main__":  # pragma: no cover
    sys.exit("this module is imported by the example scripts; run one of them instead")
