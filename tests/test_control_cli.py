"""``maniplab control``: a point-to-point move printed as JSON, and one-line errors (exit 2)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import maniplab as ml
from maniplab.cli import main
from maniplab.control.point_to_point import ControlError, parse_numbers, plan_move


def test_control_command_runs_a_move_and_prints_the_table(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture) -> None:
    # crane3 from q = (0, 0, 0.5), end-effector at (5.5, 0, 1.2): slew and luff (the slow telescope
    # hardly moves), 0.63 m in 2 s
    code = main(["control", "crane3", "--target", "5.46,0.6,1.4", "--start", "0,0,0.5",
                 "--duration", "2", "--settle", "0.5", "-o", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0
    table = json.loads(out)
    assert table["label"] == "cascade, position task"
    assert table["window"] == [0.5, 2.5]
    assert table["final_error_mm"] < 5.0 and table["rms_error_mm"] < 10.0
    assert 0.0 < table["peak_iv_A"] <= 1.0
    assert json.loads((tmp_path / "control.json").read_text()) == table
    assert (tmp_path / "control.png").stat().st_size > 10_000
    run = ml.Run.load(tmp_path / "control.npz")
    assert {"x_d", "x", "dP_d", "phi", "a_x"} <= set(run.signals)
    assert run.meta["control"]["task"] == "position"
    np.testing.assert_allclose(run["x_d"][-1, :3], [5.46, 0.6, 1.4], atol=1e-12)


@pytest.mark.parametrize(("argv", "words"), [
    (["--target", "1,x,2"], "expected comma-separated numbers"),
    (["--target", "1,2"], "expected 3 or 6 finite numbers"),
    (["--target", "40,0,1"], "closest pose within the joint limits misses it by"),
    (["--target", "5,0,1,0,0,0.2"], "needs 6 joints"),
    (["--target", "5,0,1", "--start", "0,0"], "--start '0,0': expected 3"),
    (["--target", "5,0,1", "--start", "0,0,5"], "outside its limits"),
    (["--target", "5,0,1", "--duration", "-1"], "duration must be > 0"),
    (["--target", "5,0,1", "--set", "control.pid_only.kp=[1, 2]"], "pid_only.kp has 2 gains"),
    (["--target", "5,0,1", "--set", "3"], "--set '3': expected PATH=VALUE"),
])
def test_control_command_bad_input_is_one_line_exit_2(argv: list[str], words: str,
                                                       capsys: pytest.CaptureFixture) -> None:
    args = ["control", "crane3", "--duration", "1.0", *argv]
    if args.count("--duration") > 1:
        args = ["control", "crane3", *argv]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("maniplab control: ")
    assert words in err, err


def test_an_abbreviated_option_is_refused(capsys: pytest.CaptureFixture) -> None:
    """``--set`` once meant ``--settle`` to argparse; no option may be abbreviated."""
    with pytest.raises(SystemExit) as info:
        main(["control", "crane3", "--target", "5,0,1", "--duration", "1", "--sett", "3"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unrecognized arguments: --sett 3" in err, err


def test_out_of_reach(capsys: pytest.CaptureFixture) -> None:
    assert main(["control", "planar2", "--target", "2.5,0,0", "--duration", "1"]) == 2
    assert "out of reach of planar2" in capsys.readouterr().err


def test_plan_move_checks_joint_limits() -> None:
    spec = ml.builtin_spec("crane3")
    # x = 3.5 on the arm's line needs the telescope below its lower limit 0
    with pytest.raises(ControlError, match="misses it by 1.5 m, with joint.s. telescope at"):
        plan_move(spec, [3.5, 0.0, 1.2], start=[0.0, 0.0, 0.5], duration=1.0)
    plan = plan_move(spec, [5.5, 0.0, 1.2], start=None, duration=2.0)
    assert plan.task == "position" and plan.q_start.tolist() == [0.0, 0.0, 0.0]
    # 0.5 m of telescope, whose valve gives 0.051 m/s at full current: a minimum-jerk move's
    # peak speed 1.875 L / T within 80 % of it needs T >= 23 s
    assert plan.stretched and plan.move.duration == pytest.approx(1.875 * 0.5 / (0.8 * 0.0004
                                                                                 / 0.00785),
                                                                    rel=0.05)
    assert "joint telescope" in str(plan.note())
    assert parse_numbers(" 1, -2.5 ,3e-1", "x", (3,)) == [1.0, -2.5, 0.3]


def test_control_command_records_at_the_sample_dt(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture) -> None:
    code = main(["control", "crane3", "--target", "5.46,0.6,1.4", "--start", "0,0,0.5",
                 "--duration", "2", "--settle", "0.5", "--sample-dt", "0.01",
                 "-o", str(tmp_path)])
    capsys.readouterr()
    assert code == 0
    run = ml.Run.load(tmp_path / "control.npz")
    assert run.meta["sample_dt"] == pytest.approx(0.01)
    np.testing.assert_allclose(np.diff(run.t), 0.01, atol=1e-12)
    assert len(run["x_d"]) == len(run.t) == round(run.t[-1] / 0.01) + 1  # the log resampled too
