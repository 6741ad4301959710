"""Load charts: the largest payload held at each pose, against a closed form and against the
plant itself (98 % of the charted payload is held with the valves closed, 102 % is not)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from commandline import run_cli

import maniplab as ml
from maniplab.loadchart import LoadChartError, load_chart

ARMS = Path(__file__).parent / "arms"

# one boom pitching about y: link L, mass m_l at L/2; its cylinder A (m³/rad) up to relief p_r
L, M_LINK, AREA, RELIEF, G = 4.0, 300.0, 2.0e-3, 20.0e6, 9.81
BOOM = {
    "name": "boom",
    "gravity": [0.0, 0.0, -G],
    "joints": [{"name": "luff", "type": "R", "axis": "y", "limits": [-1.2, 1.2],
                "body": {"length": L, "mass": M_LINK},
                "actuator": {"type": "hydraulic", "area": AREA, "volume": 0.002,
                             "valve_gain": 1e-3, "supply_pressure": 18.0e6,
                             "relief_pressure": RELIEF}}],
    "end_effector": {"mass": 500.0},
}


def test_one_boom_against_its_closed_form() -> None:
    """A p_r = g cos θ (m_l L/2 + m L) at the largest payload m: every pose of the grid, the
    limiting joint named, reach L cos θ and height -L sin θ (q > 0 lowers the boom)."""
    chart = load_chart(ml.ManipulatorSpec.from_dict(BOOM), points=25)
    theta = chart.q[:, 0]
    expected = (AREA * RELIEF / (G * np.cos(theta)) - M_LINK * L / 2) / L
    np.testing.assert_allclose(chart.payload, expected, rtol=1e-9)
    np.testing.assert_allclose(chart.reach, L * np.abs(np.cos(theta)), atol=1e-12)
    np.testing.assert_allclose(chart.height, -L * np.sin(theta), atol=1e-12)
    assert {chart.limiting(k) for k in range(len(theta))} == {"luff"}
    assert np.all((theta > -1.2) & (theta < 1.2))  # strictly inside the limits


def test_a_payload_hanging_off_the_end_point_against_its_closed_form() -> None:
    """A grapple whose centre of gravity is c = (cx, 0, cz) from the end point, in the boom's
    frame: its weight acts at (L + cx) cos θ + cz sin θ from the pivot, so
    A p_r = g (m_l L/2 cos θ + m ((L + cx) cos θ + cz sin θ)); its inertia plays no part. The
    chart still places the payload at the end point. Before (issue 33) the end effector had no
    ``com`` nor ``inertia``: a point mass at the end point."""
    cx, cz = 0.2, -0.5
    spec = ml.ManipulatorSpec.from_dict(BOOM).with_overrides(
        {"end_effector.com": [cx, 0.0, cz], "end_effector.inertia": [30.0, 40.0, 20.0, 0, 0, 0]})
    chart = load_chart(spec, points=25)
    theta = chart.q[:, 0]
    arm = (L + cx) * np.cos(theta) + cz * np.sin(theta)
    expected = (AREA * RELIEF / G - M_LINK * L / 2 * np.cos(theta)) / arm
    np.testing.assert_allclose(chart.payload, expected, rtol=1e-9)
    np.testing.assert_allclose(chart.reach, L * np.abs(np.cos(theta)), atol=1e-12)
    without_inertia = load_chart(spec.with_overrides({"end_effector.inertia": [0.0] * 6}),
                                 points=25)
    np.testing.assert_array_equal(without_inertia.payload, chart.payload)


def test_without_relief_the_supply_pressure_bounds_and_a_torque_source_its_limit() -> None:
    data = json.loads(json.dumps(BOOM))
    data["joints"][0]["actuator"].pop("relief_pressure")
    chart = load_chart(ml.ManipulatorSpec.from_dict(data), points=5)
    theta = chart.q[:, 0]
    expected = (AREA * 18.0e6 / (G * np.cos(theta)) - M_LINK * L / 2) / L
    np.testing.assert_allclose(chart.payload, expected, rtol=1e-9)
    data["joints"][0]["actuator"] = {"type": "torque", "limit": 5.0e4}
    chart = load_chart(ml.ManipulatorSpec.from_dict(data), points=5)
    np.testing.assert_allclose(chart.payload, (5.0e4 / (G * np.cos(theta)) - M_LINK * L / 2) / L,
                               rtol=1e-9)


def test_a_pose_the_arm_cannot_hold_at_all_is_rated_zero_naming_the_joint() -> None:
    """Issue 42: the branch for a pose where the arm alone is more than a joint holds had no test.
    With the relief at 1 MPa the boom holds its own weight only near the vertical: A p_r >= g cos θ
    m_l L/2, i.e. |cos θ| <= A p_r / (g m_l L/2) = 0.34; elsewhere the payload is 0, not negative."""
    data = json.loads(json.dumps(BOOM))
    data["joints"][0]["limits"] = [-1.5, 1.5]
    data["joints"][0]["actuator"]["relief_pressure"] = 1.0e6
    chart = load_chart(ml.ManipulatorSpec.from_dict(data), points=41)
    cos = np.abs(np.cos(chart.q[:, 0]))
    alone = AREA * 1.0e6 / (G * M_LINK * L / 2)  # the largest |cos θ| at which it holds itself
    unholdable = cos > alone
    assert unholdable.any() and (~unholdable).any()
    np.testing.assert_array_equal(chart.payload[unholdable], 0.0)
    assert {chart.limiting(k) for k in np.flatnonzero(unholdable)} == {"luff"}
    expected = (AREA * 1.0e6 / (G * cos[~unholdable]) - M_LINK * L / 2) / L
    np.testing.assert_allclose(chart.payload[~unholdable], expected, rtol=1e-9)
    assert (chart.payload >= 0.0).all()


def test_a_slew_about_the_vertical_is_charted_once() -> None:
    """crane3's slew turns the picture only: its grid is one value, the others get the points."""
    chart = load_chart("crane3", points=7)
    assert len(np.unique(chart.q[:, 0])) == 1 and len(chart.q) == 49
    assert len(np.unique(chart.q[:, 1])) == 7


def _held_drift(spec: ml.ManipulatorSpec, q: np.ndarray, payload: float) -> float:
    """The payload's largest displacement, m, over 5 s with the valves closed, starting at rest
    at q with the pressures that hold the arm there."""
    spec = spec.with_overrides({"end_effector.mass": payload})
    run = ml.simulate(spec, duration=5.0, initial={"q": q, "dP": "gravity"}, progress=False)
    return float(np.max(np.linalg.norm(run["ee_pos"] - run["ee_pos"][0], axis=1)))


@pytest.mark.parametrize("arm", ["crane3", "patu655", "excavator", "arms/excavator"])
def test_the_plant_holds_98_percent_of_the_chart_and_not_102(arm: str) -> None:
    """At 5 random poses of the chart, with no leakage and no friction (a chart counts on
    neither): 98 % of the charted payload drifts less than 1 mm in 5 s, 102 % opens the limiting
    joint's relief valve and drifts more."""
    spec = ml.load_spec(ARMS.parent / f"{arm}.yaml") if "/" in arm else ml.builtin_spec(arm)
    overrides: dict[str, object] = {}
    for joint in spec.joints:
        overrides[f"joints.{joint.name}.friction"] = {"model": "none"}
        overrides[f"joints.{joint.name}.actuator.leakage"] = 0.0
        if joint.actuator.relief_pressure is None:
            overrides[f"joints.{joint.name}.actuator.relief_pressure"] = \
                joint.actuator.supply_pressure
    spec = spec.with_overrides(overrides)
    chart = load_chart(spec, points=6)
    rng = np.random.default_rng(5)
    for k in rng.choice(np.flatnonzero(np.isfinite(chart.payload) & (chart.payload > 0)), 5,
                        replace=False):
        q, payload = chart.q[k], chart.payload[k]
        assert _held_drift(spec, q, 0.98 * payload) < 1e-3, (q, payload)
        assert _held_drift(spec, q, 1.02 * payload) > 1e-3, (q, payload, chart.limiting(k))


def test_the_command_writes_the_figure_or_every_pose(capsys, tmp_path: Path) -> None:
    code, out, err = run_cli(capsys, "loadchart", "crane3", "--points", "6",
                             "-o", str(tmp_path / "chart.json"))
    assert code == 0, err
    data = json.loads((tmp_path / "chart.json").read_text())
    chart = load_chart("crane3", points=6)
    assert data["joints"] == ["slew", "luff", "telescope"] and len(data["poses"]) == len(chart.q)
    assert [p["payload_kg"] for p in data["poses"]] == chart.payload.tolist()
    assert {p["limited_by"] for p in data["poses"]} == {"luff"}
    assert "held at 100%" in out and "limited by luff" in out
    code, out, err = run_cli(capsys, "loadchart", "crane3", "-o", str(tmp_path / "chart.png"))
    assert code == 0 and (tmp_path / "chart.png").read_bytes()[:4] == b"\x89PNG"


def test_an_arm_without_gravity_or_holding_range_is_one_line(capsys, tmp_path: Path) -> None:
    weightless = tmp_path / "weightless.yaml"
    ml.ManipulatorSpec.from_dict({**BOOM, "gravity": [0.0, 0.0, 0.0]}).dump(weightless)
    code, _, err = run_cli(capsys, "loadchart", str(weightless), "-o", str(tmp_path / "c.png"))
    assert code == 2 and err.count("\n") == 1 and "weightless.yaml: no gravity" in err
    motor = {"type": "plugins.dcmotor:GearedDCMotor", "resistance": 1.0, "inductance": 5e-3,
             "torque_constant": 0.5, "gear_ratio": 100.0}
    spec = ml.ManipulatorSpec.from_dict(BOOM).with_overrides({"joints.luff.actuator": motor})
    with pytest.raises(LoadChartError, match="joint luff.*declares no holding range"):
        load_chart(spec, points=3)
    unlimited = load_chart("planar2", points=3)  # torque sources without a limit hold anything
    assert np.isinf(unlimited.payload).all() and (unlimited.joint == -1).all()
    code, _, err = run_cli(capsys, "loadchart", "planar2", "-o", str(tmp_path / "p.png"))
    assert code == 2 and err.count("\n") == 1 and "give torque sources a limit" in err


def test_a_working_pressure_rating_and_a_safety_factor_against_the_closed_form() -> None:
    """Rated at 16 MPa with a factor of 1.25: A (p / S) = g cos θ (m_l L/2 + m L) at the largest
    payload m, every pose; and the rule says so."""
    rating, safety = 16.0e6, 1.25
    chart = load_chart(ml.ManipulatorSpec.from_dict(BOOM), points=25, rating=rating,
                       safety=safety)
    theta = chart.q[:, 0]
    expected = (AREA * rating / safety / (G * np.cos(theta)) - M_LINK * L / 2) / L
    np.testing.assert_allclose(chart.payload, expected, rtol=1e-9)
    assert "working pressure 16 MPa" in chart.rule and "safety factor of 1.25" in chart.rule


def test_a_rating_at_the_relief_setting_is_the_default_chart_of_pinned_cylinders() -> None:
    """patu655's cylinders rated at their relief setting chart exactly as by default; rated
    lower, every pose a cylinder limits holds less (and a torque or lumped joint is unchanged)."""
    default = load_chart("patu655", points=5)
    relief = ml.resolve_spec("patu655").joints[1].actuator.relief_pressure
    same = load_chart("patu655", points=5, rating=relief)
    np.testing.assert_array_equal(same.payload, default.payload)
    lower = load_chart("patu655", points=5, rating=0.8 * relief)
    limited = default.payload > 0.0
    assert np.all(lower.payload[limited] < default.payload[limited])


@pytest.mark.parametrize("option, value, words", [("--rating", "-2e7", "rating -20000000.0"),
                                                  ("--safety", "0.8", "safety factor 0.8")])
def test_a_bad_rating_or_safety_factor_is_one_line(capsys, tmp_path: Path, option: str,
                                                   value: str, words: str) -> None:
    code, _, err = run_cli(capsys, "loadchart", "patu655", f"{option}={value}", "-o",
                           str(tmp_path / "c.json"))
    assert code == 2 and words in err and err.count("\n") == 1
    assert not (tmp_path / "c.json").exists()
