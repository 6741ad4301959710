"""The validation scripts in examples/, run in their short versions, and what they must show.

The full versions (1 m in 4 s, the full segment placement) give the README's table; the short
ones here keep the same structure with smaller, quicker moves.
"""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path
from types import ModuleType

import pytest

import maniplab as ml

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def example(name: str) -> ModuleType:
    sys.path.insert(0, str(EXAMPLES))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(EXAMPLES))


def table(folder: Path, name: str) -> dict[str, dict]:
    return {row["label"]: row for row in json.loads((folder / f"{name}.json").read_text())}


def test_segment_placement(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert example("segment_placement").main(["--short", "-o", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "| case" in out and "RMS err [mm]" in out
    for name in ("segment_placement", "move_cascade"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
        assert (tmp_path / f"{name}.md").read_text().startswith("# Erector")
    placed = table(tmp_path, "segment_placement")["cascade, pose task"]
    assert placed["final_error_mm"] < 2.0 and placed["rms_error_mm"] < 5.0
    assert placed["rms_orientation_mrad"] < 20.0
    moved = table(tmp_path, "move_cascade")["cascade"]
    assert moved["final_error_mm"] < 2.0 and moved["rms_error_mm"] < 5.0
    run = ml.Run.load(tmp_path / "segment_placement-cascade--pose-task.npz")
    assert run.meta["control"]["task"] == "pose" and "dP_d" in run


def test_pid_baseline_is_much_worse(tmp_path: Path) -> None:
    assert example("pid_baseline").main(["--short", "-o", str(tmp_path)]) == 0
    rows = table(tmp_path, "move_pid_baseline")
    assert rows["PID only"]["rms_error_mm"] > 5.0 * rows["cascade"]["rms_error_mm"]


def test_payload_mismatch_stays_within_10_mm(tmp_path: Path) -> None:
    assert example("payload_mismatch").main(["--short", "-o", str(tmp_path)]) == 0
    for name in ("move_payload_mismatch", "placement_payload_mismatch"):
        rows = table(tmp_path, name)
        assert len(rows) == 3
        assert all(r["final_error_mm"] <= 10.0 for r in rows.values()), rows
