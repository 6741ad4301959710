"""Defects a forestry knuckle-boom crane found (issue 33), on tests/arms/knuckle_crane.yaml: slew
(lumped), boom and jib (pinned cylinders), telescope (prismatic, lumped), rotator (lumped, its
axis through the tip: redundant for the tip's position), one shared pump."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from commandline import run_cli

import maniplab as ml
from maniplab.control.feasibility import JointPath
from maniplab.control.point_to_point import plan_move

CRANE = Path(__file__).parent / "arms" / "knuckle_crane.yaml"
START = [-1.29, -0.44, 1.48, 0.77, 0.0]
TARGET = [7.654, -1.621, 0.035]


@pytest.fixture(scope="module")
def crane() -> tuple[ml.ManipulatorSpec, ml.AnalyticModel]:
    spec = ml.resolve_spec(CRANE)
    return spec, ml.AnalyticModel(spec)


def test_a_joint_the_tip_does_not_need_takes_no_motion_in_the_plan(crane) -> None:
    """Before: the rotator swung in the planner's joint path on the round-off of its Jacobian
    column, and the 5 s move was stretched to 54.7 s ("joint rotator would need more than 80 %
    of its actuator's command range"); in the executed run the rotator never moved."""
    spec, model = crane
    plan = plan_move(spec, TARGET, start=START, duration=5.0, model=model)
    path = JointPath.of(model, plan.move.start, plan.move.goal, plan.q_start, plan.task)
    assert np.ptp(path.q[:, 4]) < 1e-9
    assert plan.q_goal[4] == pytest.approx(START[4], abs=1e-9)
    assert plan.move.duration < 1.5 * 5.0, plan.note()
    assert "rotator" not in (plan.note() or "")


def test_control_reports_every_joints_pressures_and_commands(capsys, tmp_path) -> None:
    """Before: the table's only pressure was the lumped joints' |ΔP| (its peak on the slew)
    while a pinned cylinder's cap chamber reached several times more, and the figure drew ΔP
    and valve current of lumped joints only."""
    code, out, err = run_cli(capsys, "control", str(CRANE), "--start=" + ",".join(map(str, START)),
                             "--target", ",".join(map(str, TARGET)), "--duration", "5",
                             "--settle", "0.3", "-o", str(tmp_path))
    assert code in (0, 3), err
    table = json.loads(out)
    run = ml.Run.load(tmp_path / "control.npz")
    chambers = np.fmax(np.nan_to_num(run["pA"], nan=-1.0).max(axis=0),
                       np.nan_to_num(run["pB"], nan=-1.0).max(axis=0)) / 1e6
    for j, name in enumerate(run.spec.joint_names):
        row = table["joints"][name]
        assert row["command_unit"] == "A"
        assert row["peak_command"] == pytest.approx(np.abs(run["ctrl"][:, j]).max())
        if name in ("boom", "jib"):
            assert row["pressure"] == "pA/pB"
            assert row["peak_pressure_MPa"] == pytest.approx(chambers[j])
        else:
            assert row["pressure"] == "dP"
    assert table["peak_pressure_MPa"] == pytest.approx(max(
        r["peak_pressure_MPa"] for r in table["joints"].values()))
    assert table["peak_pressure_MPa"] > table["peak_dP_MPa"]  # a chamber beyond every ΔP


def test_compare_says_which_joints_have_no_such_signal_instead_of_empty_panels() -> None:
    """Before: `compare --signals dP,pA` on a mixed arm drew empty ±0.05 panels for the joints
    without the signal, and chose the columns by dP alone (the pinned joints left out)."""
    from maniplab.viz.plots import compare

    spec = ml.resolve_spec(CRANE)
    run = ml.simulate(spec, duration=0.2, initial={"q": START, "dP": "gravity"},
                      inputs={"boom": 0.2, "slew": 0.1})
    fig = compare([run], ["dP", "pA"])
    shown = [ax for ax in fig.axes if ax.axison]
    hidden = [ax for ax in fig.axes if not ax.axison]
    for ax in shown:  # every drawn panel has data
        assert any(np.isfinite(line.get_ydata()).any() for line in ax.get_lines()), ax.get_title()
    assert {ax.get_title().split(":")[0] for ax in shown} >= {"slew", "boom", "jib"}
    notes = [text.get_text() for ax in hidden for text in ax.texts]
    assert any("boom: no ΔP" in note and "cap-side pressure" in note for note in notes), notes
    assert any("slew: no cap-side pressure" in note for note in notes), notes


@pytest.mark.parametrize("command", ["simulate", "sweep", "crossval"])
def test_simulate_sweep_and_crossval_start_from_a_pose(capsys, tmp_path, command: str) -> None:
    """Before: only control had --start; simulate, sweep and crossval started at q = 0."""
    extra = {"simulate": ["--balanced", "-o", str(tmp_path / "run.npz")],
             "sweep": ["--balanced", "--vary", "end_effector.mass=300,400", "-o",
                       str(tmp_path / "sweep")],
             "crossval": ["-o", str(tmp_path / "cv.png")]}[command]
    code, _, err = run_cli(capsys, command, str(CRANE), "--start=" + ",".join(map(str, START)),
                           "--duration", "0.1", *extra)
    assert code == 0, err
    if command == "simulate":
        runs = [ml.Run.load(tmp_path / "run.npz")]
    elif command == "sweep":
        runs = [ml.Run.load(p) for p in sorted((tmp_path / "sweep").glob("*.npz"))]
    else:
        return  # crossval's start is checked below through its API
    for run in runs:
        np.testing.assert_allclose(run.q[0], START)
        np.testing.assert_allclose(run.q[-1], START, atol=2e-3)  # held against gravity there


def test_crossval_from_a_pose_starts_there() -> None:
    from maniplab.sim.crossval import crossvalidate

    result = crossvalidate("planar2", duration=0.2, q0=np.array([0.3, -0.2]))
    np.testing.assert_allclose(result.mujoco.q[0], [0.3, -0.2])
    np.testing.assert_allclose(result.analytic.q[0], [0.3, -0.2])
    assert result.max_deviation < 1e-6


def test_a_start_of_the_wrong_length_is_one_line(capsys, tmp_path) -> None:
    code, _, err = run_cli(capsys, "simulate", "erector", "--start=1,2", "--duration", "0.1",
                           "-o", str(tmp_path / "r.npz"))
    assert code == 2 and "--start" in err and "expected 6" in err


def test_info_shows_the_signed_moment_arm_and_the_shared_pump(capsys) -> None:
    """Before: the table printed |r| (positive) while the detail line printed r < 0, and the
    shared pump was not shown."""
    code, out, _ = run_cli(capsys, "info", str(CRANE))
    assert code == 0
    maps = ml.ActuatorMaps(CRANE)
    lo, hi = maps.spec.joints[1].limits
    r = maps.moment_arms(np.array([[0.0, q, 1.0, 0.0, 0.0] for q in np.linspace(lo, hi, 33)]))
    assert f"r {r[:, 1].min():.3g}..{r[:, 1].max():.3g} m/rad" in out
    assert "pump: 20 MPa, 150 L/min, shared by boom, jib" in out


def test_a_redundant_arm_follows_its_planned_joint_path_instead_of_parking_on_a_limit() -> None:
    """Issue 33, defect 12: from q = 0 the erector's position-task move was accepted, then the
    cascade drove the wrist joints q4 and q5 onto their limits, never moved q2, and ended 181 mm
    off (exit 3). The null space now pulls the joints towards the planner's joint path."""
    spec = ml.builtin_spec("erector")
    model = ml.AnalyticModel(spec)
    target = model.fk(np.array([0.7, 0.3, 0.2, 0.05, 0.06, 0.06]))[:3, 3]
    result = ml.control.run_move(spec, target, start=np.zeros(6), duration=1.5, settle=0.3,
                                 sample_dt=0.01)
    assert result.metrics.final_error_mm < 2.0 and result.metrics.rms_error_mm < 5.0
    assert result.health.verdict == "ok", result.health.lines()
    lower = np.array([j.limits[0] for j in spec.joints])
    upper = np.array([j.limits[1] for j in spec.joints])
    q = result.run.q[-1]
    assert np.all((q - lower > 1e-2) & (upper - q > 1e-2))  # no joint parked on a limit
    np.testing.assert_allclose(q[:2], result.plan.path.q[-1][:2], atol=0.2)  # boom, lift moved
