"""A cylinder's pins: s(q) and r(q) against rotations written here, central differences and MuJoCo's
own tendon, and the one-line errors for pins, strokes and limits that cannot work."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
import yaml
from commandline import run_cli
from scipy import optimize
from scipy.spatial.transform import Rotation

import maniplab as ml
from maniplab.actuators.hydraulic.geometry import PinGeometry

AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def _random_geometry(rng: np.random.Generator, prismatic: bool) -> tuple[PinGeometry, Any]:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    parent, child = rng.uniform(-1.5, 1.5, size=(2, 3))
    return PinGeometry(parent, child, axis, prismatic), (parent, child, axis)


def _length_by_hand(q: float, parent: np.ndarray, child: np.ndarray, axis: np.ndarray,
                    prismatic: bool) -> float:
    moved = child + q * axis if prismatic else Rotation.from_rotvec(q * axis).apply(child)
    return float(np.linalg.norm(moved - parent))


@pytest.mark.parametrize("prismatic", [False, True])
def test_length_and_arm_match_rotations_and_central_differences(prismatic: bool) -> None:
    """s(q) equals the distance of the moved pins (scipy's rotation) to 1e-12; r = ds/dq and
    dr/dq equal central differences of s and r to 1e-8 relative, away from the dead points."""
    rng = np.random.default_rng(11 + prismatic)
    checked = 0
    for _ in range(200):
        g, (p, c, a) = _random_geometry(rng, prismatic)
        q = float(rng.uniform(-2.5, 2.5))
        assert g.length(q) == pytest.approx(_length_by_hand(q, p, c, a, prismatic), rel=1e-12)
        r = float(g.arm(q))
        if abs(r) < 1e-3 * float(g.length(q)):
            continue
        h = 1e-5
        fd = (_length_by_hand(q + h, p, c, a, prismatic)
              - _length_by_hand(q - h, p, c, a, prismatic)) / (2 * h)
        assert r == pytest.approx(fd, rel=1e-8)
        slope = (float(g.arm(q + h)) - float(g.arm(q - h))) / (2 * h)
        assert float(g.arm_slope(q)) == pytest.approx(slope, rel=1e-6, abs=1e-9)
        checked += 1
    assert checked > 150


def test_span_positions_give_the_lengths_asked_for() -> None:
    """The joint range a stroke allows has the cylinder's shortest and longest lengths at its
    ends (checked with the rotation written here), and no dead point inside."""
    rng = np.random.default_rng(5)
    for prismatic in (False, True):
        for _ in range(100):
            g, (p, c, a) = _random_geometry(rng, prismatic)
            near = float(rng.uniform(-2.0, 2.0))
            low, high = g.reach(near)
            s0 = float(g.length(near))
            short, long_ = 0.5 * (low + s0), s0 + 0.5 * (min(high, 4.0 * s0) - s0)
            lo, hi = g.span(short, long_, near)
            ends = sorted(_length_by_hand(q, p, c, a, prismatic) for q in (lo, hi))
            assert ends == pytest.approx([short, long_], rel=1e-9)
            assert lo <= near <= hi
            assert not g.dead_points(lo + 1e-9, hi - 1e-9)


def _two_joint_arm(rng: np.random.Generator, prismatic: bool) -> tuple[dict[str, Any], Any]:
    """A slewing column with a random second joint driven by a random cylinder: the spec and the
    geometry (limits on one branch, the stroke spanning them)."""
    axis = str(rng.choice(list(AXES) if prismatic else ["x", "y"]))  # z would repeat the slew
    while True:
        parent, child = rng.uniform(-1.2, 1.2, size=(2, 3))
        g = PinGeometry(parent, child, AXES[axis], prismatic)
        mid = float(rng.uniform(-1.0, 1.0))
        lo, hi = mid - 0.3, mid + 0.3
        s = g.length(np.linspace(lo, hi, 3))
        if not g.dead_points(lo - 0.05, hi + 0.05) and s.min() > 0.2:
            break
    stroke = float(s.max() - s.min())
    cylinder = {"pins": {"parent": parent.tolist(), "child": child.tolist()}, "bore": 0.1,
                "rod": 0.05, "min_length": float(s.min()) * (1 - 1e-6),
                "stroke": stroke + 2e-6 * float(s.max()), "dead_volumes": [3e-4, 3e-4]}
    spec = {"name": "random", "joints": [
        {"name": "slew", "type": "R", "axis": "z",
         "body": {"length": 0.8, "direction": [0, 0, 1], "mass": 100.0}},
        {"name": "j2", "type": "P" if prismatic else "R", "axis": axis, "limits": [lo, hi],
         "body": {"length": 2.0, "direction": [0.6, 0, 0.8], "mass": 80.0},
         "actuator": {"type": "hydraulic", "cylinder": cylinder,
                      "valve": {"nominal_flow": 5e-4, "nominal_pressure_drop": 3.5e6},
                      "supply_pressure": 1.6e7}}],
        "end_effector": {"mass": 20.0}}
    return spec, g


@pytest.mark.parametrize("prismatic", [False, True])
def test_mujocos_tendon_between_the_pins_has_length_s_and_moment_r(prismatic: bool) -> None:
    """In the arm's MuJoCo model the cylinder's tendon has ten_length = s(q) and its actuator
    actuator_moment = r(q) (on the joint, 0 on the slew) to 1e-10, on random geometries."""
    rng = np.random.default_rng(3 + prismatic)
    for _ in range(12):
        data, g = _two_joint_arm(rng, prismatic)
        spec = ml.ManipulatorSpec.from_dict(data)
        model = ml.build_model(spec)
        d = mujoco.MjData(model)
        lo, hi = spec.joints[1].limits
        for _ in range(5):
            d.qpos[:] = [rng.uniform(-3, 3), rng.uniform(lo, hi)]
            mujoco.mj_forward(model, d)
            moment = np.zeros((model.nu, model.nv))
            mujoco.mju_sparse2dense(moment, d.actuator_moment, d.moment_rownnz,
                                    d.moment_rowadr, d.moment_colind)
            q = d.qpos[1]
            assert d.ten_length[0] == pytest.approx(float(g.length(q)), abs=1e-10)
            assert moment[1] == pytest.approx([0.0, float(g.arm(q))], abs=1e-10)


BOOM = {
    "name": "boom", "gravity": [0.0, 0.0, -9.81],
    "joints": [{"name": "luff", "type": "R", "axis": "y", "limits": [-1.0, 0.3],
                "body": {"length": 3.0, "direction": [1, 0, 0], "mass": 150.0},
                "actuator": {"type": "hydraulic",
                             "cylinder": {"pins": {"parent": [0.25, 0.0, -0.9],
                                                   "child": [0.9, 0.0, -0.1]},
                                          "bore": 0.1, "rod": 0.056, "min_length": 0.79,
                                          "stroke": 0.85, "dead_volumes": [2e-4, 2e-4]},
                             "valve": {"nominal_flow": 9e-4, "nominal_pressure_drop": 3.5e6},
                             "supply_pressure": 8e6, "tank_pressure": 1e5,
                             "relief_pressure": 9e6}}],
    "end_effector": {"mass": 100.0}}


def _edit(path: str, value: Any) -> dict[str, Any]:
    data = copy.deepcopy(BOOM)
    node: Any = data["joints"][0]
    keys = path.split(".")
    for key in keys[:-1]:
        node = node[key]
    if value is None:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return data


@pytest.mark.parametrize(("path", "value", "field", "words"), [
    ("actuator.cylinder.stroke", 0.6, "actuator.cylinder.stroke", "allows [-"),
    ("actuator.cylinder.min_length", 3.0, "actuator.cylinder.min_length", "apart"),
    ("limits", [-1.0, 2.5], "actuator.cylinder.pins", "moment arm vanishes at q = "),
    ("limits", None, "actuator.cylinder", "needs limits within"),
    ("actuator.cylinder.pins.child", [0.0, 0.0, 0.0], "actuator.cylinder.pins", "zero at every"),
    ("actuator.cylinder.rod", 0.1, "actuator.cylinder.rod", "not thinner than the bore"),
    ("actuator.tank_pressure", 9e6, "actuator", "not above tank_pressure"),
    ("actuator.cylinder.dead_volumes", [1e-4], "actuator.cylinder.dead_volumes", "2"),
    ("actuator.valve.flow_ratio", -1.0, "actuator.valve.flow_ratio", ""),
    ("actuator.valve.nominal_flow", None, "actuator.valve.nominal_flow", "missing"),
    ("actuator.cylinder.bore_", 0.1, "actuator.cylinder.bore_", "did you mean 'bore'"),
])
def test_pins_strokes_and_limits_that_cannot_work_are_one_line(
        capsys: pytest.CaptureFixture[str], tmp_path: Path, path: str, value: Any, field: str,
        words: str) -> None:
    """`maniplab validate` refuses the spec with exit 2 and one line naming the file, the joint,
    the field and what is wrong."""
    spec = tmp_path / "boom.yaml"
    spec.write_text(yaml.safe_dump(_edit(path, value)))
    code, out, err = run_cli(capsys, "validate", str(spec))
    assert code == 2, out + err
    line = err.strip()
    assert "\n" not in line and "Traceback" not in line
    assert str(spec) in line and "joint luff" in line and f"'{field}'" in line
    assert words in line


def test_the_boom_as_given_is_valid_and_shows_its_cylinder(capsys: pytest.CaptureFixture[str],
                                                           tmp_path: Path) -> None:
    """`maniplab info` shows the cylinder's bore, rod, stroke and its moment arm's range over the
    limits, which a rotation written here confirms."""
    spec = tmp_path / "boom.yaml"
    spec.write_text(yaml.safe_dump(BOOM))
    code, out, err = run_cli(capsys, "info", str(spec))
    assert code == 0, err
    p, c = np.array([0.25, 0.0, -0.9]), np.array([0.9, 0.0, -0.1])
    y = np.array(AXES["y"])
    q = np.linspace(-1.0, 0.3, 2001)
    s = [_length_by_hand(x, p, c, y, False) for x in q]
    arm = np.gradient(s, q)  # signed, in the table as in the detail line (issue 33)
    assert f"r {arm.min():.3g}..{arm.max():.3g} m/rad" in out
    assert "⌀100/56 x 850 mm" in out
    ends = [optimize.brentq(lambda x, length=length: _length_by_hand(x, p, c, y, False) - length,
                            -1.6, 0.9) for length in (0.79 + 0.85, 0.79)]
    assert f"its stroke allows [{ends[0]:.4g}, {ends[1]:.4g}] rad" in out
    assert "A_A 78.54 cm², A_B 53.91 cm²" in out


def test_a_run_records_the_stroke_and_the_cylinder_force(tmp_path: Path) -> None:
    """A run's ``stroke`` is s(q) - min_length and its ``cylinder_force`` times r(q) (both by
    hand) is the joint torque ``tau_act``; the force is pA A_A - pB A_B."""
    run = ml.simulate(ml.ManipulatorSpec.from_dict(BOOM), duration=0.5,
                      inputs={"luff": 0.4}, initial={"q": [-0.4], "dP": "gravity"},
                      progress=False)
    p, c, y = np.array([0.25, 0.0, -0.9]), np.array([0.9, 0.0, -0.1]), np.array(AXES["y"])
    q = run.q[:, 0]
    s = np.array([_length_by_hand(x, p, c, y, False) for x in q])
    h = 1e-6
    r = np.array([(_length_by_hand(x + h, p, c, y, False) - _length_by_hand(x - h, p, c, y, False))
                  / (2 * h) for x in q])
    assert run["stroke"][:, 0] == pytest.approx(s - 0.79, abs=1e-12)
    force = run["cylinder_force"][:, 0]
    area_a, area_b = np.pi / 4 * 0.1**2, np.pi / 4 * (0.1**2 - 0.056**2)
    assert force == pytest.approx(run["pA"][:, 0] * area_a - run["pB"][:, 0] * area_b, rel=1e-12)
    assert run["tau_act"][:, 0] == pytest.approx(force * r, rel=1e-8)
    assert np.ptp(q) > 0.05


def test_limits_copied_from_the_stroke_message_are_accepted() -> None:
    """Found by mutation testing (issue 42): the message rounded the range the stroke allows to
    6 digits outwards, so a spec using exactly those limits was refused."""
    import re

    spec = ml.builtin_spec("patu655")
    with pytest.raises(ml.SpecError, match="which allows") as refused:
        spec.with_overrides({"joints.lift.limits": [-0.9, 0.24]})
    low, high = (float(x) for x in re.search(r"allows \[([-\d.e]+), ([-\d.e]+)\]",
                                             str(refused.value)).groups())
    spec.with_overrides({"joints.lift.limits": [low, high]})  # accepted as written
