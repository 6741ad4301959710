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

import maniplab as ml
from maniplab.atomic import write_text
from maniplab.control.metrics import TrackingMetrics, format_table, to_json
from maniplab.demo.erector import MOVE_Q0, PICK_Q0, START, acceptance_move, placement_path, run_case  # noqa: F401 - re-exported for the scripts
from maniplab.viz.plots import save_figure
from maniplab.viz.tracking import tracking_figure


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


def report(name: str, title: str, cases: Sequence[tuple[ml.Run, TrackingMetrics]],
           trajectory: Any, output: Path) -> None:
    """Print the table and write ``<name>.md``, ``<name>.json``, ``<name>.png`` and the runs."""
    rows = [m for _, m in cases]
    table = format_table(rows)
    print(f"\n{title}\n\n{table}\n", flush=True)
    output.mkdir(parents=True, exist_ok=True)
    write_text(output / f"{name}.md", f"# {title}\n\n{table}\n")
    write_text(output / f"{name}.json", to_json(rows) + "\n")
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
    write_text(path, json.dumps(data, indent=2) + "\n")


if __name__ == "__main__":  # pragma: no cover
    sys.exit("this module is imported by the example scripts; run one of them instead")
