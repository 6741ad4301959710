"""simulate, sweep, compare, runs and crossval on the command line."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from commandline import run_cli

import maniplab as ml


def test_simulate_writes_the_run_with_inputs_and_overrides(capsys, tmp_path: Path) -> None:
    path = tmp_path / "runs" / "heavy.npz"
    code, out, _ = run_cli(capsys, "simulate", "planar2", "--input", "q1=step:2@0.05",
                           "--input", "q1=1", "--set", "end_effector.mass=0.5",
                           "--duration", "0.2", "-o", str(path))
    assert code == 0 and str(path) in out
    run = ml.Run.load(path)
    assert run.spec.end_effector.mass == 0.5
    assert run.t[-1] == pytest.approx(0.2)
    assert np.isclose(run["tau_act"][0, 0], 1.0)  # before the step: the constant 1 N·m only
    assert np.isclose(run["tau_act"][-1, 0], 3.0)  # after: step 2 + constant 1


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--input", "q2=stp:1"], "unknown signal 'stp'"),
        (["--input", "q9=1"], "q9"),
        (["--set", "end_effector.mas=3"], "did you mean 'mass'"),
        (["--set", "end_effector.mass=heavy"], "end_effector.mass"),
    ],
)
def test_bad_simulate_arguments_exit_2_with_one_line(capsys, tmp_path: Path, argv, words) -> None:
    code, _, err = run_cli(capsys, "simulate", "planar2", "--duration", "0.1", *argv,
                           "-o", str(tmp_path / "x.npz"))
    assert code == 2 and len(err.strip().splitlines()) == 1 and words in err
    assert not (tmp_path / "x.npz").exists()


def test_sweep_runs_compare_pipeline(capsys, tmp_path: Path) -> None:
    code, out, _ = run_cli(capsys, "sweep", "planar2", "--vary", "end_effector.mass=0.5,2",
                           "--vary", "joints.q2.friction.viscous=0,1", "--input", "q1=5",
                           "--duration", "0.2", "--processes", "2", "-o", str(tmp_path / "sw"))
    assert code == 0
    files = sorted((tmp_path / "sw").glob("*.npz"))
    assert len(files) == 4
    code, out, _ = run_cli(capsys, "runs", str(tmp_path / "sw"))
    header = out.splitlines()[0].split()
    assert header == ["file", "q2", "viscous", "payload"]
    assert len(out.splitlines()) == 2 + 4
    figure = tmp_path / "fig.svg"
    code, out, _ = run_cli(capsys, "compare", *map(str, files), "--signals", "q,qd",
                           "-o", str(figure))
    assert code == 0 and figure.read_text().count("payload=") >= 4
    assert [line.split(": ", 1)[1] for line in out.splitlines()[1:]] == ["ok"] * 4  # verdicts


def test_crossval_prints_a_tiny_deviation(capsys, tmp_path: Path) -> None:
    code, out, _ = run_cli(capsys, "crossval", "planar2", "--duration", "1",
                           "-o", str(tmp_path / "cv.png"))
    assert code == 0
    deviation = float(re.search(r"largest deviation (\S+)", out).group(1))
    assert deviation < 1e-6
    assert (tmp_path / "cv.png").read_bytes().startswith(b"\x89PNG")


def test_runs_of_a_missing_folder_is_one_line(capsys, tmp_path: Path) -> None:
    code, _, err = run_cli(capsys, "runs", str(tmp_path / "nope"))
    assert code == 2 and "not a folder" in err


RECORDING = {"simulate": ["planar2", "--duration", "0.1"],
             "sweep": ["planar2", "--vary", "end_effector.mass=1,2", "--duration", "0.1"],
             "control": ["planar2", "--target", "1,0,1", "--duration", "1"]}
"""Every command that records a run, with its required arguments."""


@pytest.mark.parametrize("command", sorted(RECORDING))
@pytest.mark.parametrize(("value", "words"), [("0", "positive number of seconds, got 0"),
                                              ("-0.1", "got -0.1"), ("nan", "got nan"),
                                              ("1e400", "got 1e400"),
                                              ("fast", "'fast' is not a number of seconds")])
def test_bad_sample_dt_is_one_line_naming_the_option(capsys, tmp_path: Path, command: str,
                                                     value: str, words: str) -> None:
    out = tmp_path / "out"
    code, _, err = run_cli(capsys, command, *RECORDING[command], f"--sample-dt={value}",
                           "-o", str(out))
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert err.startswith(f"maniplab {command}: error: argument --sample-dt: ") and words in err
    assert not out.exists()


def test_sweep_records_at_the_sample_dt(capsys, tmp_path: Path) -> None:
    code, _, err = run_cli(capsys, *["sweep", *RECORDING["sweep"]], "--sample-dt", "0.02",
                           "--processes", "1", "-o", str(tmp_path / "sw"))
    assert code == 0, err
    runs = [ml.Run.load(path) for path in sorted((tmp_path / "sw").glob("*.npz"))]
    assert len(runs) == 2
    for run in runs:
        np.testing.assert_allclose(run.t, np.arange(6) * 0.02, atol=1e-12)  # 0, 0.02, ..., 0.1
