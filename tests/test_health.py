"""The health verdict of a run: each check on a run made to trip it (by the plant, or written
out as signals), and healthy runs that stay "ok"."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import maniplab as ml
from maniplab.cli import main
from maniplab.control.move import run_move
from maniplab.control.point_to_point import plan_move
from maniplab.friction import FrictionMode

ARMS = Path(__file__).parent / "arms"


def lift(**actuator: object) -> ml.ManipulatorSpec:
    params = {"type": "hydraulic", "area": 2e-3, "volume": 2e-3, "valve_gain": 1e-3,
              "supply_pressure": 20e6, **actuator}
    return ml.ManipulatorSpec.from_dict({"name": "lift", "joints": [
        {"name": "lift", "type": "P", "axis": "z", "limits": [-3.0, 0.5],
         "body": {"mass": 2000.0}, "actuator": params}]})


def written(spec: ml.ManipulatorSpec, t: np.ndarray, meta: dict | None = None,
            **signals: np.ndarray) -> ml.Run:
    """A run from signals written out here (each (N, n) unless given otherwise)."""
    n = spec.n
    base = {"q": np.zeros((len(t), n)), "qd": np.zeros((len(t), n)),
            "ctrl": np.zeros((len(t), n)), "mode": np.zeros((len(t), n), dtype=np.int8)}
    return ml.Run(t=t, signals={**base, **signals}, spec=spec, meta=meta or {})


def checks(run: ml.Run) -> set[tuple[str, str | None]]:
    return {(f.check, f.joint) for f in run.health.findings}


def test_a_healthy_closed_loop_move_is_ok() -> None:
    result = run_move(ml.builtin_spec("crane3"), [5.46, 0.6, 1.4], start=[0.0, 0.0, 0.5],
                      duration=3.0, settle=0.5)
    assert result.health.verdict == "ok" and result.missed() is None


def test_a_move_too_fast_saturates_its_valve() -> None:
    spec = ml.builtin_spec("crane3")
    plan = plan_move(spec, [5.46, 0.6, 1.4], start=[0.0, 0.0, 0.5], duration=3.0)
    fast = ml.MinJerkMove(plan.move.start, plan.move.goal, 0.5, t0=0.2)
    run = ml.simulate(spec, controller=ml.CascadeController(spec, fast, task="position"),
                      duration=1.5, initial={"q": plan.q_start, "dP": "gravity"})
    assert ("saturation", "slew") in checks(run)
    # the valve cannot follow, so the arm misses its reference: a failure, not a warning
    assert ("tracking", None) in checks(run) and run.health.verdict == "failed"


def test_a_run_that_ends_a_metre_off_its_target_is_never_ok() -> None:
    """Issue 41: the PID baseline on the loader crane ended 998 mm off and its health said ok."""
    spec = ml.resolve_spec(ARMS / "loader_crane.yaml")
    target = ml.AnalyticModel(spec).fk(np.array([0.4, -0.4, 1.0, 1.2]))[:3, 3]
    result = run_move(spec, target, start=[0.0, -0.6, 1.2, 0.5], duration=6.0, mode="pid")
    assert result.metrics.final_error_mm > 100.0  # measured from the move, independently
    assert result.health.verdict == "failed"
    (finding,) = [f for f in result.health.findings if f.check == "tracking"]
    assert f"final position error {result.metrics.final_error_mm:.3g} mm > 2 mm" in finding.cause


def test_the_tolerances_of_a_move_set_the_tracking_check() -> None:
    spec = ml.builtin_spec("crane3")
    loose = run_move(spec, [5.46, 0.6, 1.4], start=[0.0, 0.0, 0.5], duration=3.0, settle=0.2,
                     mode="pid", tolerances=(1e3, 1e3))
    tight = run_move(spec, [5.46, 0.6, 1.4], start=[0.0, 0.0, 0.5], duration=3.0, settle=0.2,
                     mode="pid", tolerances=(1e-3, 1e-3))
    assert "tracking" not in {f.check for f in loose.health.findings}
    assert "tracking" in {f.check for f in tight.health.findings}
    assert tight.run.meta["reference"]["final_mm"] == 1e-3
    assert tight.run.units()["p_ref"] == "m"


def test_open_loop_saturation_is_the_users_own_input() -> None:
    run = ml.simulate(lift(), inputs={"lift": 1.0}, duration=0.2, initial={"dP": "gravity"})
    assert "saturation" not in {f.check for f in run.health.findings}


def test_pressure_beyond_supply_is_a_warning_and_beyond_relief_a_failure() -> None:
    # the paper's law lowering a load: the oscillation grows past the supply pressure
    run = ml.simulate(lift(valve_law="paper"), inputs={"lift": ml.signals.step(-0.6, t0=0.1)},
                      duration=2.0, initial={"dP": "gravity"})
    found = {f.check: f for f in run.health.findings}
    assert found["bounds"].joint == "lift" and "supply pressure" in found["bounds"].cause
    assert run.health.verdict == "warnings"
    spec = lift(relief_pressure=15e6)
    t = np.linspace(0.0, 1.0, 101)
    beyond = written(spec, t, dP=np.full((101, 1), 15.3e6))  # above 1.01 × 15 MPa
    assert beyond.health.verdict == "failed" and "relief pressure" in beyond.health.summary()


def test_a_joint_pinned_on_its_limit() -> None:
    run = ml.simulate(lift(), inputs={"lift": 0.5}, duration=4.0, initial={"dP": "gravity"})
    assert np.any(run["mode"] == FrictionMode.AT_UPPER)
    assert ("pinned", "lift") in checks(run)


def test_a_commanded_joint_that_does_not_move_fails() -> None:
    spec = lift()
    t = np.linspace(0.0, 1.0, 101)
    frozen = written(spec, t, ctrl=np.full((101, 1), 0.5))
    assert frozen.health.verdict == "failed" and ("still", "lift") in checks(frozen)
    moving = written(spec, t, ctrl=np.full((101, 1), 0.5), q=np.linspace(0, 0.1, 101)[:, None])
    assert ("still", "lift") not in checks(moving)


def test_a_diverging_loop_fails_once_the_reference_rests() -> None:
    spec = ml.builtin_spec("planar2")
    t = np.linspace(0.0, 2.0, 201)
    x_d = np.zeros((201, 6))
    x_d[:100, 0] = np.linspace(0.0, 0.1, 100)  # moves, then rests at 0.1 from sample 99
    x_d[100:, 0] = x_d[99, 0]
    grows = np.zeros((201, 6))
    grows[:, 0] = 1e-3 * np.exp(2.0 * t)  # 7 mm at 1 s, 55 mm at 2 s
    run = written(spec, t, x_d=x_d, e_x=grows)
    assert ("diverging", None) in checks(run) and run.health.verdict == "failed"
    settles = grows.copy()
    settles[:, 0] = 5e-3 * np.exp(-3.0 * t)
    assert "diverging" not in {f.check for f in written(spec, t, x_d=x_d, e_x=settles)
                               .health.findings}


def test_the_health_survives_a_round_trip_through_a_file(tmp_path: Path) -> None:
    run = ml.simulate(lift(), inputs={"lift": 0.5}, duration=2.0, initial={"dP": "gravity"})
    run.save(tmp_path / "run.npz")
    assert ml.Run.load(tmp_path / "run.npz").health == run.health


def test_control_exits_3_naming_joint_cause_and_setting(tmp_path: Path, capsys) -> None:
    spec = ml.builtin_spec("crane3").with_overrides({"control.position.kp": 1e4,
                                                    "control.position.kd": 1.0})
    path = tmp_path / "unstable.yaml"
    spec.dump(path)
    code = main(["control", str(path), "--target", "5.46,0.6,1.4", "--start", "0,0,0.5",
                 "--duration", "3", "--settle", "1", "-o", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 3
    assert err[-1].startswith("maniplab control: the move missed its tolerances")
    assert "control.position" in err[-1] or "joint" in err[-1]


def test_an_impact_on_a_limit_is_reported_with_its_speed_and_energy() -> None:
    """crane3's luff driven at full command into its upper limit: one impact, at the last
    speed recorded before the stop, with ½ M_jj v² from the analytic model's mass matrix at the
    stop (independent of MuJoCo's); a rating above it silences the finding."""
    from maniplab.sim.health import impacts

    inputs = {"luff": ml.signals.step(1.0, 0.1)}
    start = {"q": [0.0, -0.3, 0.5], "dP": "gravity"}
    run = ml.simulate("crane3", duration=1.6, inputs=inputs, initial=start)
    ((joint, t, speed, energy),) = impacts(run)
    k = int(np.searchsorted(run.t, t))
    before = run.qd[k - 3:k, 1]
    assert joint == "luff" and speed == pytest.approx(abs(before[before != 0.0][-1]), rel=1e-12)
    mass = ml.AnalyticModel(run.spec).M(run.q[k])[1, 1]
    assert energy == pytest.approx(0.5 * mass * speed**2, rel=1e-9)
    (finding,) = [f for f in run.health.findings if f.check == "impact"]
    assert finding.joint == "luff" and f"{speed:.3g} rad/s" in finding.cause
    rated = ml.simulate("crane3", duration=1.6, inputs=inputs, initial=start,
                        overrides={"joints.luff.stop_energy": 2.0 * energy})
    assert not [f for f in rated.health.findings if f.check == "impact"]
