"""Tests of maniplab.mjcf_gen: the MuJoCo model of a spec and its MJCF text.

Every physical check is against something the code under test did not compute: the MJCF text loaded
by plain MuJoCo, the paper's eq. (1) chain written out by hand from the YAML numbers, Spong's
closed-form two-link dynamics, and sums of the YAML masses (read with plain PyYAML).

``boundmass``/``boundinertia`` lift massless bodies (the planar arm's end-effector) to 1e-12 kg and
1e-12 kg·m²; comparisons against closed forms allow that documented absolute perturbation.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import maniplab
from maniplab import ManipulatorSpec, ModelError
from maniplab.mjcf_gen import (
    END_EFFECTOR,
    body_name,
    build_mjspec,
    build_model,
    to_mjcf,
    write_mjcf,
)
from maniplab.mjcf_gen.writer import serialize

ASSETS = Path(maniplab.__file__).parent / "assets"
BOUND = 1e-12  # the documented compiler.boundmass / boundinertia
RNG_SEED = 7


def _yaml(name: str) -> dict[str, Any]:
    """A built-in spec file read with plain PyYAML (no maniplab code)."""
    return yaml.safe_load((ASSETS / f"{name}.yaml").read_text())


def _state(model: mujoco.MjModel, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    low = np.where(model.jnt_limited, model.jnt_range[:, 0], -np.pi)
    high = np.where(model.jnt_limited, model.jnt_range[:, 1], np.pi)
    return rng.uniform(low, high), rng.normal(size=model.nv)


def _dynamics(model: mujoco.MjModel, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M(q), shape (n, n), and qfrc_bias(q, qd) = C qd + G, shape (n,)."""
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = q, qd
    mujoco.mj_forward(model, data)
    mass = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, mass)
    return mass, data.qfrc_bias.copy()


def _assert_close(actual: np.ndarray, expected: np.ndarray, rel: float, atol: float = 0.0) -> None:
    scale = max(float(np.max(np.abs(expected))), 1e-300)
    np.testing.assert_allclose(actual, expected, rtol=0.0, atol=rel * scale + atol)


# --- 1. the MJCF text gives the same model as MjSpec ---------------------------------------------

_SAME_ARRAYS = ["body_parentid", "body_pos", "body_quat", "body_ipos", "body_iquat", "body_mass", "body_inertia", "jnt_type", "jnt_bodyid", "jnt_axis", "jnt_pos", "jnt_limited", "jnt_range", "actuator_trntype", "actuator_trnid", "actuator_dyntype", "actuator_gaintype", "actuator_biastype", "actuator_gear", "actuator_ctrllimited", "actuator_ctrlrange", "actuator_actnum", "actuator_gainprm", "geom_type", "geom_size", "geom_pos", "geom_quat", "geom_contype", "geom_conaffinity", "cam_pos", "cam_quat", "cam_mode"]


def _assert_same_model(spec: ManipulatorSpec, states: int = 3) -> None:
    try:
        built = build_model(spec)
        loaded = mujoco.MjModel.from_xml_string(to_mjcf(spec))
    except ModelError:
        # a model maniplab refuses (a joint moving nothing) must still serialise faithfully
        with pytest.raises(ModelError):
            to_mjcf(spec)
        built = build_mjspec(spec).compile()
        loaded = mujoco.MjModel.from_xml_string(serialize(build_mjspec(spec)))
    for name in _SAME_ARRAYS:
        assert np.array_equal(getattr(built, name), getattr(loaded, name)), name
    for name in ("gravity", "timestep", "integrator"):
        assert np.array_equal(getattr(built.opt, name), getattr(loaded.opt, name)), name
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(states):
        q, qd = _state(built, rng)
        mass_b, bias_b = _dynamics(built, q, qd)
        mass_l, bias_l = _dynamics(loaded, q, qd)
        _assert_close(mass_l, mass_b, 1e-12)
        _assert_close(bias_l, bias_b, 1e-12)


@pytest.mark.parametrize("name", maniplab.builtin_specs())
def test_builtin_mjcf_loads_into_the_same_model(name: str) -> None:
    _assert_same_model(maniplab.builtin_spec(name), states=5)


def _floats(low: float, high: float) -> st.SearchStrategy[float]:
    return st.floats(low, high, allow_nan=False, allow_infinity=False)


def _vec3(low: float, high: float) -> st.SearchStrategy[list[float]]:
    return st.lists(_floats(low, high), min_size=3, max_size=3)


_UNIT = _vec3(-1.0, 1.0).filter(lambda v: math.dist(v, (0, 0, 0)) > 0.2).map(
    lambda v: [c / math.dist(v, (0, 0, 0)) for c in v]
)


@st.composite
def _inertias(draw: st.DrawFn) -> list[float]:
    """A rigid body's inertia: principal moments obeying the triangle inequality, rotated."""
    a, b = draw(_floats(0.01, 10.0)), draw(_floats(0.01, 10.0))
    c = draw(st.sampled_from([abs(a - b), a + b]) | _floats(abs(a - b), a + b))  # plates too
    quat = np.array(draw(st.lists(_floats(-1.0, 1.0), min_size=4, max_size=4)))
    rot = np.eye(3)
    if np.linalg.norm(quat) > 0.1:
        w, x, y, z = quat / np.linalg.norm(quat)
        rot = np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
            ]
        )
    i = rot @ np.diag([a, b, c]) @ rot.T
    return [float(v) for v in (i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2])]


@st.composite
def _bodies(draw: st.DrawFn) -> dict[str, Any] | None:
    # every kind the spec allows; full bodies weighted up so that most arms are simulable
    kind = draw(st.sampled_from(["none", "massless", "rod", "full", "full", "full", "point"]))
    if kind == "none":
        return None
    body: dict[str, Any] = {"length": draw(_floats(0.0, 2.0)), "direction": draw(_UNIT)}
    if kind != "massless":
        body["mass"] = draw(_floats(0.1, 100.0))
    if kind in ("full", "point"):
        body["com"] = draw(_vec3(-1.0, 1.0))
        body["inertia"] = draw(_inertias()) if kind == "full" else [0.0] * 6
    return body


@st.composite
def _joints(draw: st.DrawFn, index: int) -> dict[str, Any]:
    joint: dict[str, Any] = {
        "name": f"j{index}",
        "type": draw(st.sampled_from(["R", "P"])),
        "axis": draw(st.sampled_from(["x", "y", "z"])),
    }
    if draw(st.booleans()):
        low = draw(_floats(-3.0, 2.9))
        joint["limits"] = [low, draw(_floats(low + 0.05, 3.0))]
    body = draw(_bodies())
    if body is not None:
        joint["body"] = body
    if draw(st.booleans()):
        joint["actuator"] = {
            "type": "hydraulic",
            "area": 1e-3,
            "volume": 1e-3,
            "valve_gain": 1e-4,
            "supply_pressure": 1e7,
            "current_limit": draw(_floats(0.1, 2.0)),
        }
    elif draw(st.booleans()):
        joint["actuator"] = {"type": "torque", "limit": draw(_floats(1.0, 1e4))}
    return joint


@st.composite
def _specs(draw: st.DrawFn) -> ManipulatorSpec:
    n = draw(st.integers(1, 7))
    data = {
        "name": "random",
        "gravity": draw(_vec3(-12.0, 12.0)),
        "joints": [draw(_joints(i)) for i in range(n)],
        "end_effector": {
            "mass": draw(st.sampled_from([0.0, 1.0, 50.0]) | _floats(0.1, 200.0)),
            "offset": draw(_vec3(-0.5, 0.5)),
        },
    }
    return ManipulatorSpec.from_dict(data)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_specs())
def test_random_mjcf_loads_into_the_same_model(spec: ManipulatorSpec) -> None:
    _assert_same_model(spec)


def test_mjcf_keeps_full_precision() -> None:
    third = 1.0 / 3.0
    spec = ManipulatorSpec.from_dict(
        {
            "name": "thirds",
            "joints": [
                {
                    "type": "R",
                    "axis": "z",
                    "body": {
                        "length": third,
                        "direction": [1.0, 0.0, 0.0],
                        "mass": third,
                        "inertia": [0.1, 0.2, 0.25, 0.01, third * 1e-3, 0.0],
                    },
                }
            ],
            "end_effector": {"mass": 1.0},
        }
    )
    xml = to_mjcf(spec)
    assert "fullinertia" in xml and "diaginertia" not in xml
    model = mujoco.MjModel.from_xml_string(xml)
    tip = model.body(END_EFFECTOR)
    assert tip.pos[0] == third  # exactly the double 1/3, not 0.333333
    assert model.body(body_name("q1")).mass[0] == third


@pytest.mark.parametrize("seed", range(20))
def test_principal_inertia_is_the_specs(seed: int) -> None:
    # flat plates (A + B = C) and heavy rotated rods sit on the edge of MuJoCo's triangle check
    rng = np.random.default_rng(seed)
    rot, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    a, b = rng.uniform(0.1, 500.0, size=2)
    principal = [a, b, a + b] if seed % 2 else [0.0, a, a]
    inertia = rot @ np.diag(principal) @ rot.T
    six = [float(inertia[i, j]) for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))]
    spec = ManipulatorSpec.from_dict(
        {
            "name": "plate",
            "joints": [
                {"type": "R", "axis": "z",
                 "body": {"length": 1.0, "direction": [1, 0, 0], "mass": 100.0, "inertia": six}}
            ],
        }
    )
    model = mujoco.MjModel.from_xml_string(to_mjcf(spec))
    moments = np.sort(model.body(body_name("q1")).inertia)
    expected = np.maximum(np.sort(principal), BOUND)
    np.testing.assert_allclose(moments, expected, rtol=0, atol=1e-11 * max(principal))


# --- 2. frames: MuJoCo bodies sit where the paper's eq. (1) puts them ------------------------------


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    r = {
        "x": [[1, 0, 0], [0, c, -s], [0, s, c]],
        "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]],
        "z": [[c, -s, 0], [s, c, 0], [0, 0, 1]],
    }[axis]
    t = np.eye(4)
    t[:3, :3] = r
    return t


def _trans(v: Any) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = v
    return t


def _eq1_chain(data: dict[str, Any], q: np.ndarray) -> tuple[list, list, np.ndarray]:
    """Eq. (1) by hand: per joint, frame j · motion(q_j) and the COG; and the payload position."""
    frame = np.eye(4)
    moved, cogs = [], []
    for joint, qj in zip(data["joints"], q):
        axis = joint["axis"]
        prismatic = joint["type"] in ("P", "Tr")
        unit = {"x": [1, 0, 0], "y": [0, 1, 0], "z": [0, 0, 1]}[axis]
        motion = _trans(np.multiply(qj, unit)) if prismatic else _rot(axis, qj)
        after = frame @ motion
        body = joint.get("body", {})
        length = body.get("length", 0.0)
        direction = np.array(body.get("direction", [1.0, 0.0, 0.0]), dtype=float)
        com = np.array(body.get("com", 0.5 * length * direction), dtype=float)
        moved.append(after)
        cogs.append((after @ np.append(com, 1.0))[:3])
        frame = after @ _trans(length * direction)
    offset = data.get("end_effector", {}).get("offset", [0.0, 0.0, 0.0])
    return moved, cogs, (frame @ np.append(offset, 1.0))[:3]


@pytest.mark.parametrize("name", ["planar2", "erector"])
def test_bodies_follow_eq1(name: str) -> None:
    data = _yaml(name)
    model = build_model(maniplab.builtin_spec(name))
    mjdata = mujoco.MjData(model)
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(10):
        q, _ = _state(model, rng)
        mjdata.qpos[:] = q
        mujoco.mj_kinematics(model, mjdata)
        moved, cogs, payload = _eq1_chain(data, q)
        for joint, pose, cog in zip(data["joints"], moved, cogs):
            body = mjdata.body(body_name(joint["name"]))
            np.testing.assert_allclose(body.xpos, pose[:3, 3], rtol=0, atol=1e-12)
            np.testing.assert_allclose(body.xmat.reshape(3, 3), pose[:3, :3], rtol=0, atol=1e-12)
            if "body" in joint:
                np.testing.assert_allclose(body.xipos, cog, rtol=0, atol=1e-12)
        np.testing.assert_allclose(mjdata.body(END_EFFECTOR).xpos, payload, rtol=0, atol=1e-12)
        np.testing.assert_allclose(mjdata.site(END_EFFECTOR).xpos, payload, rtol=0, atol=1e-12)


# --- 3. closed form: Spong's two-link arm ----------------------------------------------------------


def _spong(data: dict[str, Any], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M(q) and g(q) of Spong, Hutchinson & Vidyasagar sec. 7.4.1 (uniform rods, gravity -y)."""
    (l1, m1), (l2, m2) = [(j["body"]["length"], j["body"]["mass"]) for j in data["joints"]]
    lc1, lc2 = l1 / 2, l2 / 2
    i1, i2 = m1 * l1**2 / 12, m2 * l2**2 / 12
    g = -data["gravity"][1]
    c2 = math.cos(q[1])
    d11 = m1 * lc1**2 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * c2) + i1 + i2
    d12 = m2 * (lc2**2 + l1 * lc2 * c2) + i2
    d22 = m2 * lc2**2 + i2
    g1 = (m1 * lc1 + m2 * l1) * g * math.cos(q[0]) + m2 * lc2 * g * math.cos(q[0] + q[1])
    g2 = m2 * lc2 * g * math.cos(q[0] + q[1])
    return np.array([[d11, d12], [d12, d22]]), np.array([g1, g2])


def test_planar2_matches_spong() -> None:
    data = _yaml("planar2")
    assert data["gravity"][0] == data["gravity"][2] == 0.0 and data["end_effector"]["mass"] == 0.0
    model = build_model(maniplab.builtin_spec("planar2"))
    # the massless end-effector is lifted to BOUND kg and BOUND kg·m² at up to 2 m from the base
    bound = BOUND * (1.0 + 2.0**2) * 2
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(20):
        q = rng.uniform(-np.pi, np.pi, size=2)
        mass, bias = _dynamics(model, q, np.zeros(2))
        mass_spong, gravity_spong = _spong(data, q)
        _assert_close(mass, mass_spong, 1e-12, atol=bound)
        _assert_close(bias, gravity_spong, 1e-12, atol=bound * 9.81)


# --- 4. arms MuJoCo could compile but nobody could simulate -------------------------------------


def _one_joint(joint: dict[str, Any], ee_mass: float = 0.0) -> ManipulatorSpec:
    return ManipulatorSpec.from_dict(
        {"name": "bad", "joints": [joint], "end_effector": {"mass": ee_mass}}, source="bad.yaml"
    )


@pytest.mark.parametrize(
    "spec",
    [
        # rotation about a slender rod's own axis: the rod has no inertia about it
        _one_joint({"name": "spin", "type": "R", "axis": "x",
                    "body": {"length": 1.0, "direction": [1, 0, 0], "mass": 5.0}}),
        # a point mass on the joint axis
        _one_joint({"name": "spin", "type": "R", "axis": "z",
                    "body": {"length": 1.0, "direction": [0, 0, 1], "mass": 5.0}}, ee_mass=3.0),
        # a prismatic joint moving nothing
        _one_joint({"name": "spin", "type": "P", "axis": "y"}),
    ],
    ids=["rod-about-own-axis", "mass-on-axis", "nothing-moved"],
)
def test_joint_driving_no_mass_is_refused(spec: ManipulatorSpec) -> None:
    for make in (build_model, to_mjcf):
        with pytest.raises(ModelError, match=r"bad\.yaml.*joint spin drives no mass"):
            make(spec)


def test_joints_moving_the_arm_alike_are_refused() -> None:
    rod = {"length": 1.0, "direction": [1, 0, 0], "mass": 2.0}
    spec = ManipulatorSpec.from_dict(
        {
            "name": "twins",
            "joints": [
                {"name": "a", "type": "R", "axis": "z"},
                {"name": "b", "type": "R", "axis": "z", "body": rod},
            ],
        },
        source="twins.yaml",
    )
    with pytest.raises(ModelError, match=r"twins\.yaml.*joints a and b move the arm the same way"):
        build_model(spec)


def test_singular_pose_alone_is_accepted() -> None:
    # q1 about z sees the arm only through q2's offset: M[0, 0] = 0 at q2 = 0 but not elsewhere
    spec = ManipulatorSpec.from_dict(
        {
            "name": "slide-out",
            "joints": [
                {"type": "R", "axis": "z"},
                {"type": "P", "axis": "x", "limits": [0.0, 1.0]},
            ],
            "end_effector": {"mass": 10.0},
        }
    )
    model = build_model(spec)
    assert model.nv == 2


# --- 5. what a person sees, and what it must not change ------------------------------------------


@pytest.mark.parametrize("name", maniplab.builtin_specs())
def test_visual_items_present_and_inert(name: str) -> None:
    data = _yaml(name)
    xml = to_mjcf(maniplab.builtin_spec(name))
    root = ET.fromstring(xml)
    geoms = root.iter("geom")
    types = {g.get("type", "sphere") for g in geoms}
    rotational = any(j["type"] == "R" for j in data["joints"])
    prismatic = any(j["type"] in ("P", "Tr") for j in data["joints"])
    assert {"capsule", "box", "plane"} <= types
    assert ("cylinder" in types) == rotational
    assert len(root.findall(".//geom[@type='box']")) >= 1 + prismatic  # payload (+ rails)
    assert root.findall(".//camera") and root.findall(".//light")
    offscreen = root.find("visual/global")
    assert int(offscreen.get("offwidth")) >= 1280 and int(offscreen.get("offheight")) >= 720

    model = mujoco.MjModel.from_xml_string(xml)
    assert not model.geom_contype.any() and not model.geom_conaffinity.any()
    floor = model.geom("floor")
    gravity = np.array(data["gravity"]) / np.linalg.norm(data["gravity"])
    normal = np.zeros(9)
    mujoco.mju_quat2Mat(normal, floor.quat)
    np.testing.assert_allclose(normal.reshape(3, 3)[:, 2], -gravity, atol=1e-12)
    assert float(floor.pos @ gravity) > 0.0  # below the base, along gravity

    masses = [j["body"].get("mass", 0.0) for j in data["joints"] if "body" in j]
    yaml_total = sum(masses) + data.get("end_effector", {}).get("mass", 0.0)
    bounds = BOUND * (model.nbody - 1)
    assert abs(model.body_mass.sum() - yaml_total) <= 1e-12 * yaml_total + bounds


def test_actuators_are_named_after_joints_and_ready_for_the_plant() -> None:
    data = _yaml("erector")
    model = build_model(maniplab.builtin_spec("erector"))
    for joint in data["joints"]:
        act = model.actuator(joint["name"])
        limit = joint["actuator"]["current_limit"]
        assert model.actuator_ctrllimited[act.id] and list(act.ctrlrange) == [-limit, limit]
        assert model.actuator_actnum[act.id] == 2  # ΔP and Q
        assert model.jnt_range[model.joint(joint["name"]).id].tolist() == joint["limits"]

    # the hydraulics live in the model and in its MJCF as plain MuJoCo loads it (the engine
    # plugin maniplab.hydraulic): the force is A ΔP, and the states move as eq. (4) says
    areas = [j["actuator"]["area"] for j in data["joints"]]
    for mj_model in (model, mujoco.MjModel.from_xml_string(to_mjcf("erector"))):
        mjdata = mujoco.MjData(mj_model)
        mjdata.ctrl[:] = 0.5
        mjdata.act[:] = np.tile([8e6, 2e-3], 6)  # ΔP (Pa) and Q (m³/s) of each cylinder
        mujoco.mj_forward(mj_model, mjdata)
        np.testing.assert_allclose(mjdata.actuator_force, 8e6 * np.array(areas), rtol=1e-15)
        np.testing.assert_allclose(mjdata.qfrc_actuator, 8e6 * np.array(areas), rtol=1e-15)
        mujoco.mj_step(mj_model, mjdata)
        assert np.all(mjdata.act[0::2] != 8e6) and np.all(np.isfinite(mjdata.qpos))


def _foreign_dyn(m, d, i):
    return 0.0


def _foreign_bias(m, d, i):
    return 0.0


def test_models_compile_while_python_callbacks_are_installed() -> None:
    """MuJoCo calls the actuator callbacks while compiling, before Python ones can be handed the
    model; building suspends whatever is installed and gives it back."""
    mujoco.set_mjcb_act_dyn(_foreign_dyn)
    mujoco.set_mjcb_act_bias(_foreign_bias)
    try:
        with pytest.raises(ValueError):  # what happens without the suspension
            build_mjspec("erector").compile()
        assert build_model("erector").nu == 6
        assert "<actuator>" in to_mjcf("erector")
        assert maniplab.Plant("erector").model.nu == 6  # six cylinders
        assert mujoco.get_mjcb_act_dyn() is _foreign_dyn
        assert mujoco.get_mjcb_act_bias() is _foreign_bias
    finally:
        mujoco.set_mjcb_act_dyn(None)
        mujoco.set_mjcb_act_bias(None)


def test_torque_actuator_applies_the_command() -> None:
    model = build_model(maniplab.builtin_spec("planar2"))
    mjdata = mujoco.MjData(model)
    mjdata.ctrl[:] = [3.5, -1.25]
    mujoco.mj_forward(model, mjdata)
    assert mjdata.qfrc_actuator.tolist() == [3.5, -1.25]
    assert not model.actuator_ctrllimited.any()  # planar2 gives no limits


def test_write_mjcf_is_atomic_and_loadable(tmp_path: Path) -> None:
    target = tmp_path / "out" / "erector.xml"
    written = write_mjcf("erector", target)
    assert written == target and os.listdir(target.parent) == ["erector.xml"]
    model = mujoco.MjModel.from_xml_path(str(target))
    assert model.nu == len(_yaml("erector")["joints"])


def test_names_are_resolved_and_unknown_ones_refused() -> None:
    assert build_model("planar2").nv == 2
    with pytest.raises(maniplab.SpecError, match="no-such-arm"):
        build_model("no-such-arm")


def test_writer_refuses_elements_it_would_lose() -> None:
    s = build_mjspec("planar2")
    s.add_sensor(type=mujoco.mjtSensor.mjSENS_JOINTPOS, objtype=mujoco.mjtObj.mjOBJ_JOINT,
                 objname="q1")
    with pytest.raises(NotImplementedError, match="sensors"):
        serialize(s)


def _rod_inertial(body: mujoco.MjsBody, mass: float, length: float) -> None:
    """An explicit inertial (the writer's way): a rod of ``length`` along x from the body's origin,
    with a little inertia about its own axis."""
    body.explicitinertial = True
    body.mass = mass
    body.ipos = [length / 2, 0.0, 0.0]
    body.fullinertia = [1e-3, mass * length**2 / 12, mass * length**2 / 12, 0.0, 0.0, 0.0]


def _cylinder_spec() -> mujoco.MjSpec:
    """Two hinged links and a hydraulic cylinder between them: a spatial tendon from a site on the
    parent to one on the child, pushed by a general actuator."""
    s = mujoco.MjSpec()
    parent = s.worldbody.add_body(name="parent", pos=[0.0, 0.0, 0.1])
    parent.add_joint(name="shoulder", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 0.0, 1.0])
    _rod_inertial(parent, mass=2.0, length=0.6)
    parent.add_site(name="barrel", pos=[0.1, 1.0 / 3.0, 0.0])
    child = parent.add_body(name="child", pos=[0.6, 0.0, 0.0])
    child.add_joint(name="elbow", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 1.0, 0.0])
    _rod_inertial(child, mass=1.0, length=0.5)
    child.add_site(name="rod", pos=[0.2, 0.0, 0.1 / 3.0])
    cylinder = s.add_tendon(name="cylinder", width=0.0125, rgba=[0.2, 0.3, 0.7, 1.0])
    cylinder.stiffness = [1.0 / 7.0, 0.0, 0.0]
    cylinder.damping = [0.3, 0.0, 0.0]
    cylinder.springlength = [0.55, 0.55]
    cylinder.limited = mujoco.mjtLimited.mjLIMITED_TRUE
    cylinder.range = [0.1, 1.2]
    cylinder.wrap_site("barrel")
    cylinder.wrap_site("rod")
    s.add_actuator(name="cylinder", target="cylinder", trntype=mujoco.mjtTrn.mjTRN_TENDON,
                   gear=[2.0 / 3.0, 0, 0, 0, 0, 0], ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE,
                   ctrlrange=[-100.0, 100.0])
    return s


def _dense_moment(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    moment = np.zeros((model.nu, model.nv))
    mujoco.mju_sparse2dense(moment, data.actuator_moment, data.moment_rownnz, data.moment_rowadr,
                            data.moment_colind)
    return moment


def test_spatial_tendon_on_sites_round_trips() -> None:
    """A site-to-site cylinder and its actuator load from the MJCF text as MjSpec compiles them."""
    s = _cylinder_spec()
    xml = serialize(s)
    sections = [child.tag for child in ET.fromstring(xml)]
    assert sections.index("worldbody") < sections.index("tendon") < sections.index("actuator")
    built, loaded = s.compile(), mujoco.MjModel.from_xml_string(xml)
    assert built.ntendon == loaded.ntendon == 1
    for name in ("barrel", "rod"):
        assert loaded.site(name).id == built.site(name).id
    for name in ["tendon_width", "tendon_rgba", "tendon_limited", "tendon_range",
                 "tendon_stiffness", "tendon_damping", "tendon_lengthspring", "wrap_type",
                 "wrap_objid", "site_bodyid", "site_pos", "actuator_trntype", "actuator_trnid",
                 "actuator_gear", "actuator_ctrllimited", "actuator_ctrlrange"]:
        assert np.array_equal(getattr(built, name), getattr(loaded, name)), name
    assert loaded.actuator_trntype[0] == mujoco.mjtTrn.mjTRN_TENDON
    assert loaded.actuator_gear[0, 0] == 2.0 / 3.0
    rng = np.random.default_rng(RNG_SEED)
    data_b, data_l = mujoco.MjData(built), mujoco.MjData(loaded)
    for _ in range(3):
        data_b.qpos[:] = data_l.qpos[:] = rng.uniform(-np.pi, np.pi, size=built.nq)
        data_b.qvel[:] = data_l.qvel[:] = rng.normal(size=built.nv)
        mujoco.mj_forward(built, data_b)
        mujoco.mj_forward(loaded, data_l)
        np.testing.assert_allclose(data_l.ten_length, data_b.ten_length, rtol=0, atol=1e-12)
        np.testing.assert_allclose(_dense_moment(loaded, data_l), _dense_moment(built, data_b),
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(data_l.qfrc_passive, data_b.qfrc_passive, rtol=0, atol=1e-12)
        # the cylinder's length is the distance between its two sites
        ends = data_l.site("rod").xpos - data_l.site("barrel").xpos
        assert abs(data_l.ten_length[0] - np.linalg.norm(ends)) <= 1e-12


def _wrap_geom(s: mujoco.MjSpec) -> None:
    s.body("child").add_geom(name="pin", size=[0.02, 0.0, 0.0])
    s.tendons[0].wrap_geom("pin", "")


def _fixed_tendon(s: mujoco.MjSpec) -> None:
    s.add_tendon(name="coupling").wrap_joint("elbow", 1.0)


@pytest.mark.parametrize("extend, what", [(_wrap_geom, "geom wraps of tendon 'cylinder'"),
                                          (_fixed_tendon, "joint wraps of tendon 'coupling'")],
                         ids=["geom-wrap", "fixed"])
def test_writer_refuses_tendons_it_would_lose(extend: Any, what: str) -> None:
    s = _cylinder_spec()
    extend(s)
    with pytest.raises(NotImplementedError, match=what):
        serialize(s)
