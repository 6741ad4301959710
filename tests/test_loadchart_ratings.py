"""Load charts as crane makers rate them (issue 39): tipping over the base's footprint, each
joint's structural limit and the slew on a slope, against closed forms written here; the spec's
``base`` and ``max_moment``; the command's flags."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from commandline import run_cli

import maniplab as ml
from maniplab.errors import SpecError
from maniplab.loadchart import LoadChartError, load_chart

G = 9.81
# A slew about z (a post H high, its mass at mid-height on the axis) carrying a horizontal
# telescope along x: the boom's mass M_BOOM at (s + L/2) from the axis, the payload at s + L.
# Both driven by torque sources without a limit: nothing but tipping limits the payload.
H, L, M_POST, M_BOOM = 0.5, 2.0, 100.0, 150.0
# The machine: its mass at (X_BASE, 0, Z_BASE), on a rectangle x in [-A, B], y in [-W, W] at
# height GROUND.
M_BASE, X_BASE, Z_BASE, GROUND = 4000.0, -0.8, 0.4, -1.0
A, B, W = 2.5, 1.2, 1.0
SLEW_LIMITS = (-3.0, 3.0)
ARM = {
    "name": "tipper",
    "gravity": [0.0, 0.0, -G],
    "joints": [
        {"name": "slew", "type": "R", "axis": "z", "limits": list(SLEW_LIMITS),
         "body": {"length": H, "direction": [0, 0, 1], "mass": M_POST}},
        {"name": "telescope", "type": "P", "axis": "x", "limits": [0.5, 4.0],
         "body": {"length": L, "mass": M_BOOM}},
    ],
    "end_effector": {"mass": 200.0},
    "base": {"mass": M_BASE, "com": [X_BASE, 0.0, Z_BASE], "ground": GROUND,
             "footprint": [[-A, -W], [B, -W], [B, W], [-A, W]]},
}


def _tipping_payload(theta: np.ndarray, s: np.ndarray, slope_deg: float = 0.0,
                     m_base: float = M_BASE) -> np.ndarray:
    """By hand: the machine stands while every edge's moment about it keeps the centre of gravity
    inside. On a slope α falling along +x, gravity is g (sin α, 0, -cos α): a point at height z
    above the ground shifts by (z - ground) tan α along x on its way down to the ground. 0 where
    the machine tips without a payload."""
    shift = math.tan(math.radians(slope_deg))
    c, si = np.cos(theta), np.sin(theta)
    # points (x, y) on the ground; the post's and the boom's mass and the payload
    post = (0.0 + (H / 2 - GROUND) * shift, 0.0)
    boom = ((s + L / 2) * c + (H - GROUND) * shift, (s + L / 2) * si)
    load = ((s + L) * c + (H - GROUND) * shift, (s + L) * si)
    base = (X_BASE + (Z_BASE - GROUND) * shift, 0.0)
    m0 = m_base + M_POST + M_BOOM
    sx = m_base * base[0] + M_POST * post[0] + M_BOOM * boom[0]
    sy = m_base * base[1] + M_POST * post[1] + M_BOOM * boom[1]
    best = np.full(np.shape(theta), np.inf)
    bare = np.zeros(np.shape(theta), dtype=bool)
    # edges: x = B (outward +x), x = -A (-x), y = W (+y), y = -W (-y); the payload tips the
    # machine over an edge it lies beyond: m (p - d) = d m0 - S (per unit normal)
    for normal, d in (((1, 0), B), ((-1, 0), A), ((0, 1), W), ((0, -1), W)):
        room = d * m0 - (normal[0] * sx + normal[1] * sy)
        beyond = normal[0] * load[0] + normal[1] * load[1] - d
        bare |= room < 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            best = np.minimum(best, np.where(beyond > 0.0, room / beyond, np.inf))
    return np.where(bare, 0.0, best)


@pytest.mark.parametrize("slope", [0.0, 4.0])
def test_the_tipping_line_of_a_boom_on_a_slew_over_a_rectangle(slope: float) -> None:
    """Every pose's payload is the hand-computed tipping payload over the stability factor, to
    1e-6, and its cause is "tipping" wherever the payload's point lies beyond an edge."""
    stability = 1.25
    chart = load_chart(ml.ManipulatorSpec.from_dict(ARM), points=12, stability=stability,
                       slope=slope)
    theta, s = chart.q[:, 0], chart.q[:, 1]
    expected = _tipping_payload(theta, s, slope) / stability
    tips = np.isfinite(expected)
    assert tips.all()  # the payload, 2.5 m out at least, always lies beyond an edge
    np.testing.assert_allclose(chart.payload[tips], expected[tips], rtol=1e-6)
    assert set(chart.cause[tips]) == {"tipping"} and (chart.joint[tips] == -1).all()
    assert chart.slews == (0,) and chart.shape == (12, 12)
    # all round: each pose is rated at the least over the slew's angles, the telescope as it is
    rated = chart.payload[chart.all_round()].reshape(12, 12)
    np.testing.assert_allclose(rated, np.broadcast_to(
        (expected.reshape(12, 12)).min(axis=0), (12, 12)), rtol=1e-6)


def test_the_tipping_edge_is_the_one_by_hand() -> None:
    """Each pose names the edge with the least tipping payload by hand (the footprint's corners
    kept counter-clockwise from [-A, -W]: edge 0 is y = -W, 1 x = B, 2 y = W, 3 x = -A); the
    front edge x = B where the boom points straight ahead."""
    chart = load_chart(ml.ManipulatorSpec.from_dict(ARM), points=12)
    theta, s = chart.q[:, 0], chart.q[:, 1]
    edges = {0: ((0, -1), W), 1: ((1, 0), B), 2: ((0, 1), W), 3: ((-1, 0), A)}
    m0 = M_BASE + M_POST + M_BOOM
    sx = M_BASE * X_BASE + M_BOOM * (s + L / 2) * np.cos(theta)
    sy = M_BOOM * (s + L / 2) * np.sin(theta)
    each = []
    for (nx, ny), d in edges.values():
        beyond = nx * (s + L) * np.cos(theta) + ny * (s + L) * np.sin(theta) - d
        with np.errstate(divide="ignore", invalid="ignore"):
            each.append(np.where(beyond > 0, (d * m0 - nx * sx - ny * sy) / beyond, np.inf))
    np.testing.assert_array_equal(chart.edge, np.argmin(each, axis=0))
    assert {int(chart.edge[k]) for k in range(len(theta)) if abs(theta[k]) < 0.3} == {1}
    ahead = int(np.flatnonzero(np.abs(theta) < 0.3)[0])
    assert "edge [1.2, -1.0]-[1.2, 1.0]" in chart.describe(ahead)


def test_a_machine_that_tips_bare_at_a_pose_is_rated_zero() -> None:
    """A light base: with the telescope out, the boom alone tips it (its moment about an edge
    beats the rest's), so those poses are rated 0 for tipping; the others as by hand."""
    spec = ml.ManipulatorSpec.from_dict({**ARM, "base": {**ARM["base"], "mass": 100.0}})
    chart = load_chart(spec, points=12)
    theta, s = chart.q[:, 0], chart.q[:, 1]
    expected = _tipping_payload(theta, s, m_base=100.0)
    bare = expected == 0.0
    assert bare.any() and (~bare).any()
    np.testing.assert_array_equal(chart.payload[bare], 0.0)
    assert set(chart.cause[bare]) == {"tipping"}
    tips = np.isfinite(expected)
    np.testing.assert_allclose(chart.payload[tips], expected[tips], rtol=1e-6)


# One boom pitching about y, as in test_loadchart: link L_B, mass M_L at L_B/2, its cylinder of
# area AREA (m³/rad) up to the relief RELIEF, and a structural limit on the luff.
L_B, M_L, AREA, RELIEF = 4.0, 300.0, 2.0e-3, 20.0e6
BOOM = {
    "name": "boom",
    "gravity": [0.0, 0.0, -G],
    "joints": [{"name": "luff", "type": "R", "axis": "y", "limits": [-1.2, 1.2],
                "body": {"length": L_B, "mass": M_L}, "max_moment": 3.0e4,
                "actuator": {"type": "hydraulic", "area": AREA, "volume": 0.002,
                             "valve_gain": 1e-3, "supply_pressure": 18.0e6,
                             "relief_pressure": RELIEF}}],
    "end_effector": {"mass": 500.0},
}


def test_a_structural_limit_against_the_hand_computed_moment() -> None:
    """The luff carries g cos θ (m_l L/2 + m L) N·m: its structure (3e4 N·m, below the
    cylinder's A p_r = 4e4) limits every pose at M = g cos θ (m_l L/2 + m L); with a safety
    factor of 2 the holding (2e4) is less and limits it again. The factor does not divide the
    structural limit, an allowable load already."""
    spec = ml.ManipulatorSpec.from_dict(BOOM)
    chart = load_chart(spec, points=15)
    theta = chart.q[:, 0]
    moment = 3.0e4
    np.testing.assert_allclose(chart.payload,
                               (moment / (G * np.cos(theta)) - M_L * L_B / 2) / L_B, rtol=1e-9)
    assert set(chart.cause) == {"structure"} and {chart.limiting(k) for k in range(15)} == {"luff"}
    # the moment the chart's payload puts on the luff is the limit
    np.testing.assert_allclose(G * np.cos(theta) * (M_L * L_B / 2 + chart.payload * L_B), moment,
                               rtol=1e-9)
    safe = load_chart(spec, points=15, safety=2.0)
    np.testing.assert_allclose(safe.payload,
                               (AREA * RELIEF / 2.0 / (G * np.cos(theta)) - M_L * L_B / 2) / L_B,
                               rtol=1e-9)
    assert set(safe.cause) == {"holding"}
    assert "structural limits" in chart.rule


def test_the_slope_loads_the_slew_as_the_closed_form_says() -> None:
    """On level ground the slew carries nothing: no limit. On a slope α falling along +x the
    boom's and the payload's weights turn it by g sin α sin θ (m_b r_b + m r): a slew drive of
    limit T holds m = (T / (g sin α |sin θ|) - m_b r_b) / r, r = s + L, r_b = s + L/2; a smaller
    structural limit on the slew binds in its place."""
    limit, slope = 2.0e3, 5.0
    spec = ml.ManipulatorSpec.from_dict({**ARM, "base": None}).with_overrides(
        {"joints.slew.actuator": {"type": "torque", "limit": limit}})
    level = load_chart(spec, points=8)
    assert np.isinf(level.payload).all() and level.slews == ()
    chart = load_chart(spec, points=8, slope=slope)
    theta, s = chart.q[:, 0], chart.q[:, 1]
    turn = G * math.sin(math.radians(slope)) * np.abs(np.sin(theta))
    expected = (limit / turn - M_BOOM * (s + L / 2)) / (s + L)
    np.testing.assert_allclose(chart.payload, np.maximum(expected, 0.0), rtol=1e-9)
    assert set(chart.cause) == {"holding"} and set(chart.joint) == {0}
    carried = load_chart(spec.with_overrides({"joints.slew.max_moment": 0.5 * limit}), points=8,
                         slope=slope)
    expected = (0.5 * limit / turn - M_BOOM * (s + L / 2)) / (s + L)
    np.testing.assert_allclose(carried.payload, np.maximum(expected, 0.0), rtol=1e-9)
    assert set(carried.cause) == {"structure"}
    assert "on a 5° slope" in carried.rule


def test_a_spec_with_a_base_and_structural_limits_round_trips(tmp_path: Path) -> None:
    spec = ml.ManipulatorSpec.from_dict(ARM).with_overrides({"joints.slew.max_moment": 5e3})
    spec.dump(tmp_path / "tipper.yaml")
    again = ml.load_spec(tmp_path / "tipper.yaml")
    assert again == spec and again.base is not None and again.joints[0].max_moment == 5e3
    # the footprint's corners given clockwise are kept counter-clockwise
    clockwise = ml.ManipulatorSpec.from_dict(
        {**ARM, "base": {**ARM["base"], "footprint": [[-A, W], [B, W], [B, -W], [-A, -W]]}})
    assert clockwise.base.footprint == ((-A, -W), (B, -W), (B, W), (-A, W))
    # rating data: the MuJoCo model and the URDF are the same with or without them
    bare = ml.ManipulatorSpec.from_dict({**ARM, "base": None})
    assert ml.to_mjcf(spec) == ml.to_mjcf(bare) and ml.to_urdf(spec) == ml.to_urdf(bare)


@pytest.mark.parametrize("where, value, field, words", [
    ("base", {"mass": -5.0, "footprint": [[-1, -1], [1, -1], [1, 1]]}, "base.mass",
     "expected a number > 0"),
    ("base", {"mass": 100.0, "footprint": [[-1, -1], [1, 1], [1, -1], [-1, 1]]},
     "base.footprint", "not a convex polygon"),
    ("base", {"mass": 100.0, "footprint": [[0, 0], [1, 0], [2, 0]]}, "base.footprint",
     "not a convex polygon"),
    ("base", {"mass": 100.0, "footprint": [[0, 0], [1, 0]]}, "base.footprint", "2 corners"),
    ("base", {"mass": 100.0, "com": [3.0, 0.0, 0.0], "footprint": [[-1, -1], [1, -1], [1, 1],
                                                                   [-1, 1]]},
     "base", "the bare machine tips"),
    ("max_moment", -3.0, "max_moment", "expected a number > 0"),
])
def test_a_bad_base_or_structural_limit_is_one_line_naming_the_field(
        tmp_path: Path, where: str, value: object, field: str, words: str) -> None:
    data = json.loads(json.dumps(ARM))
    if where == "base":
        data["base"] = value
    else:
        data["joints"][1]["max_moment"] = value
    path = tmp_path / "bad.yaml"
    path.write_text(json.dumps(data))  # JSON is YAML
    with pytest.raises(SpecError) as info:
        ml.load_spec(path)
    message = str(info.value)
    assert "\n" not in message and str(path) in message and f"field '{field}'" in message
    assert words in message
    if where == "max_moment":
        assert "joint telescope" in message


def test_the_command_rates_with_stability_and_slope(capsys, tmp_path: Path) -> None:
    spec = tmp_path / "tipper.yaml"
    ml.ManipulatorSpec.from_dict(ARM).dump(spec)
    code, out, err = run_cli(capsys, "loadchart", str(spec), "--points", "6", "--stability",
                             "1.25", "--slope", "3", "-o", str(tmp_path / "c.json"))
    assert code == 0, err
    data = json.loads((tmp_path / "c.json").read_text())
    chart = load_chart(spec, points=6, stability=1.25, slope=3.0)
    assert [p["payload_kg"] for p in data["poses"]] == [
        float(m) if math.isfinite(m) else None for m in chart.payload]
    assert {p["cause"] for p in data["poses"]} == {"tipping"}
    assert data["slope_deg"] == 3.0 and "stability factor of 1.25" in data["rule"]
    assert "tipping at" in out and "limited by tipping over the footprint's edge" in out
    # --set gives a built-in arm a base
    code, out, err = run_cli(capsys, "loadchart", "crane3", "--points", "5", "--set",
                             "joints.luff.max_moment=1e3", "-o", str(tmp_path / "s.png"))
    assert code == 0, err
    assert "structure at 100%" in out and (tmp_path / "s.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("option, value, words", [
    ("--stability", "0.9", "stability factor 0.9"),
    ("--slope", "95", "slope 95.0"),
    ("--slope", "-1", "slope -1.0"),
    ("--slope", "nan", "slope nan"),
    ("--set", "base={mass: -1, footprint: [[-1, -1], [1, -1], [1, 1]]}", "field 'base.mass'"),
    ("--set", "joints.lift.max_moment=0", "joint lift, field 'max_moment'"),
])
def test_a_bad_flag_is_one_line(capsys, tmp_path: Path, option: str, value: str,
                                words: str) -> None:
    code, _, err = run_cli(capsys, "loadchart", "patu655", f"{option}={value}", "-o",
                           str(tmp_path / "c.json"))
    assert code == 2 and words in err and err.count("\n") == 1, err
    assert not (tmp_path / "c.json").exists()


def test_a_bad_factor_in_python_is_an_error() -> None:
    with pytest.raises(LoadChartError, match="stability factor 0.5"):
        load_chart(ml.ManipulatorSpec.from_dict(ARM), points=3, stability=0.5)
