"""The URDF export (maniplab.urdf, ``maniplab export -f urdf``) against Pinocchio's URDF parser.

Pinocchio reads the file with its own parser (urdfdom) and computes M(q) with CRBA and G(q) with
RNEA: independent code from a file, checked against the analytic model on every built-in arm, every
corpus arm (tests/arms), random general arms (maniplab.sample) and an arm with the corner cases
(unlimited prismatic and rotational joints, bodyless joints, a massless body, no payload).
"""

from __future__ import annotations

import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from commandline import run_cli

import maniplab as ml
from maniplab.sample import sample_arm

ARMS = Path(__file__).parent / "arms"
NS = "urn:maniplab:urdf:1"
TOL = 1e-12

EDGES = {
    "name": "edges",
    "gravity": [1.5, -2.0, -9.0],
    "joints": [
        {"name": "slide", "type": "P", "axis": "x"},  # no limits, no body
        {"name": "turn", "type": "R", "axis": "y",  # no limits: continuous
         "body": {"length": 0.5, "direction": [0.0, 0.6, 0.8], "mass": 2.0,
                  "com": [0.1, -0.2, 0.3], "inertia": [0.3, 0.4, 0.5, 0.01, -0.02, 0.03]},
         "actuator": {"type": "torque", "limit": 50.0}},
        {"name": "tilt", "type": "R", "axis": "x", "limits": [-1.0, 1.0],
         "body": {"length": 0.4, "direction": [1.0, 0.0, 0.0]},  # massless body
         "actuator": {"type": "plugins.dcmotor:GearedDCMotor", "resistance": 0.5,
                      "inductance": 2e-3, "torque_constant": 0.1, "gear_ratio": 50}},
        {"name": "end_effector_fixed", "type": "P", "axis": "z", "limits": [-0.2, 0.4],
         "body": {"length": 0.3, "direction": [0.0, 0.0, 1.0], "mass": 1.5},
         "friction": {"model": "lugre", "coulomb": 2.0, "viscous": 0.5}},
    ],
}


# a rotator turning a grapple whose centre of gravity is off the rotator's axis, with a full
# inertia tensor (issue 33: before, the end effector was a point mass in the URDF too)
GRAPPLE_OFF_AXIS = ml.load_spec(ARMS / "mixed" / "forestry_grapple.yaml").with_overrides(
    {"end_effector.com": [0.06, -0.04, -0.45], "end_effector.inertia": [8.0, 12.0, 9.0, 0.4, -0.3,
                                                                         0.2]})


def specs() -> dict[str, ml.ManipulatorSpec]:
    out = {name: ml.builtin_spec(name) for name in ml.builtin_specs()}
    out |= {f"arms/{p.stem}": ml.load_spec(p) for p in sorted(ARMS.glob("*.yaml"))}
    out |= {f"arms/mixed/{p.stem}": ml.load_spec(p) for p in sorted((ARMS / "mixed").glob("*.yaml"))}
    out |= {"sample7": sample_arm(7, seed=0), "sample5": sample_arm(5, seed=3),
            "edges": ml.ManipulatorSpec.from_dict(EDGES), "grapple_off_axis": GRAPPLE_OFF_AXIS}
    return out


SPECS = specs()


def pinocchio_model(spec: ml.ManipulatorSpec) -> pin.Model:
    """The URDF as Pinocchio loads it, with the spec's gravity (URDF has none)."""
    model = pin.buildModelFromXML(ml.to_urdf(spec))
    model.gravity.linear = np.array(spec.gravity, dtype=float)
    return model


def pinocchio_q(model: pin.Model, q: np.ndarray) -> np.ndarray:
    """Pinocchio's configuration of joint positions q: a continuous joint is (cos q, sin q)."""
    parts = [[math.cos(x), math.sin(x)] if joint.nq == 2 else [x]
             for x, joint in zip(q, model.joints[1:])]
    return np.array([v for part in parts for v in part])


def random_q(spec: ml.ManipulatorSpec, rng: np.random.Generator) -> np.ndarray:
    """Joint positions within the limits (±π rad or ±2 m where a joint has none)."""
    return np.array([rng.uniform(*j.limits) if j.limits else
                     rng.uniform(-2.0, 2.0) if j.prismatic else rng.uniform(-math.pi, math.pi)
                     for j in spec.joints])


@pytest.mark.parametrize("name", SPECS)
def test_pinocchio_gives_the_analytic_m_and_g(name: str) -> None:
    spec = SPECS[name]
    model = pinocchio_model(spec)
    assert list(model.names[1:]) == list(spec.joint_names) and model.nv == spec.n
    data, am = model.createData(), ml.AnalyticModel(spec)
    rng = np.random.default_rng(7)
    qs = [random_q(spec, rng) for _ in range(8)]
    M_pin, G_pin = [], []
    for q in qs:
        upper = pin.crba(model, data, pinocchio_q(model, q)).copy()  # upper triangle filled
        M_pin.append(np.triu(upper) + np.triu(upper, 1).T)
        G_pin.append(pin.computeGeneralizedGravity(model, data, pinocchio_q(model, q)).copy())
    M_am, G_am = am.M(np.array(qs)), am.G(np.array(qs))
    # Relative to the largest entry: the erector's M reaches 1e5 kg·m², where one rounding is
    # ~1e-11, so an absolute 1e-12 would ask for less than a double resolves. G uses the largest
    # entry over all the states (an arm whose gravity is along its joint axes has G = 0 exactly
    # and must then give exactly 0).
    M_err = max(np.abs(a - b).max() / np.abs(b).max() for a, b in zip(M_pin, M_am))
    G_scale = np.abs(G_am).max()
    G_err = np.abs(np.array(G_pin) - G_am).max() / G_scale if G_scale else np.abs(G_pin).max()
    print(f"{name}: max relative error M {M_err:.1e}, G {G_err:.1e}", file=sys.stderr)
    assert M_err <= TOL, f"{name}: M differs by {M_err:.3e} relative"
    assert G_err <= TOL, f"{name}: G differs by {G_err:.3e} relative"


def test_gravity_must_be_given_to_pinocchio() -> None:
    """Without the spec's gravity (the erector's is along -y) Pinocchio's default -z gives
    another G: the comparison above would catch a URDF that carried none of it."""
    spec = SPECS["erector"]
    model = pin.buildModelFromXML(ml.to_urdf(spec))
    q = np.array([0.3, 0.5, -0.2, 0.1, 0.1, 0.2])
    default = pin.computeGeneralizedGravity(model, model.createData(), q)
    assert np.abs(default - ml.AnalyticModel(spec).G(q)).max() > 1e3


def extension(spec: ml.ManipulatorSpec) -> ET.Element:
    root = ET.fromstring(ml.to_urdf(spec))
    found = root.findall(f"{{{NS}}}model")
    assert len(found) == 1
    return found[0]


def unflatten(attributes: dict[str, str]) -> dict[str, Any]:
    """The attributes as nested text (``a.b="x"`` -> {"a": {"b": "x"}})."""
    out: dict[str, Any] = {}
    for key, text in attributes.items():
        *path, last = key.split(".")
        node = out
        for part in path:
            node = node.setdefault(part, {})
        node[last] = text
    return out


def parse_like(text: str, value: Any) -> Any:
    """Text read back as the type of the spec's value."""
    if isinstance(value, bool):
        assert text in ("true", "false")
        return text == "true"
    if isinstance(value, (int, float)):
        return float(text)
    if isinstance(value, (list, tuple)):
        return [float(t) for t in text.split()]
    return text


def plain(data: dict[str, Any]) -> dict[str, Any]:
    """Spec data without the unset (None) parameters, the form the extension writes."""
    return {k: plain(v) if isinstance(v, dict) else (list(v) if isinstance(v, tuple) else v)
            for k, v in data.items() if v is not None}


def read_back(text: dict[str, Any], like: dict[str, Any]) -> dict[str, Any]:
    assert set(text) == set(like), (sorted(text), sorted(like))
    return {k: read_back(t, like[k]) if isinstance(t, dict) else parse_like(t, like[k])
            for k, t in text.items()}


WITH_SUPPLY = ml.ManipulatorSpec.from_dict({**ml.builtin_spec("erector_pinned").to_dict(),
                                            "supply": {"pressure": 20.0e6, "max_flow": 1.5e-3,
                                                       "ls_margin": 2.0e6, "response": 0.03}})


@pytest.mark.parametrize("name", [*SPECS, "erector_pinned+supply"])
def test_the_extension_round_trips_actuators_friction_and_gravity(name: str) -> None:
    spec = WITH_SUPPLY if name == "erector_pinned+supply" else SPECS[name]
    model = extension(spec)
    assert model.get("version") == "1"
    assert [float(g) for g in model.get("gravity", "").split()] == list(spec.gravity)
    joints = model.findall(f"{{{NS}}}joint")
    assert [j.get("name") for j in joints] == list(spec.joint_names)
    data = spec.to_dict()
    for element, joint in zip(joints, data["joints"]):
        for section in ("actuator", "friction"):
            (child,) = element.findall(f"{{{NS}}}{section}")
            expected = plain(joint[section])
            assert read_back(unflatten(dict(child.attrib)), expected) == expected, \
                (name, joint["name"], section)
    supply = model.findall(f"{{{NS}}}supply")
    if spec.supply is None:
        assert supply == []
    else:
        written = {k: v for k, v in data["supply"].items() if v is not None}  # None: unset
        assert read_back(unflatten(dict(supply[0].attrib)), written) == written


@pytest.mark.parametrize("name", SPECS)
def test_joint_limits_and_kinds_are_the_specs(name: str) -> None:
    spec = SPECS[name]
    root = ET.fromstring(ml.to_urdf(spec))
    joints = {j.get("name"): j for j in root.findall("joint")}
    for joint in spec.joints:
        element = joints[joint.name]
        kind = element.get("type")
        limit = element.find("limit")
        if joint.prismatic:
            assert kind == "prismatic" and limit is not None
        else:
            assert kind == ("revolute" if joint.limits else "continuous")
        bounds = (joint.limits if joint.limits else
                  (-sys.float_info.max, sys.float_info.max) if joint.prismatic else None)
        if bounds is None:
            assert limit is None or "lower" not in limit.attrib
        else:
            assert limit is not None
            assert (float(limit.get("lower", "nan")), float(limit.get("upper", "nan"))) == bounds
        axis = element.find("axis")
        assert axis is not None
        assert axis.get("xyz", "").split() == [repr(float(v)) for v in joint.axis_vector]
    model = pinocchio_model(spec)
    for k, joint in enumerate(spec.joints):  # Pinocchio reads the same limits
        if joint.limits:
            iq = model.joints[k + 1].idx_q
            assert model.lowerPositionLimit[iq] == joint.limits[0]
            assert model.upperPositionLimit[iq] == joint.limits[1]


def test_effort_and_velocity_come_from_the_actuators() -> None:
    root = ET.fromstring(ml.to_urdf(SPECS["edges"]))
    limits = {j.get("name"): j.find("limit") for j in root.findall("joint")}
    turn = limits["turn"]
    assert turn is not None
    assert float(turn.get("effort", "nan")) == 50.0  # the torque source's limit
    assert float(turn.get("velocity", "nan")) == sys.float_info.max  # no speed bound
    erector = ET.fromstring(ml.to_urdf(SPECS["erector"]))
    q1 = erector.find("joint[@name='q1']/limit")
    assert q1 is not None
    actuator = SPECS["erector"].joints[0].actuator  # a lumped cylinder: A p, C i_max / A
    assert float(q1.get("effort", "nan")) == actuator.area * (actuator.relief_pressure
                                                               or actuator.supply_pressure)
    assert math.isclose(float(q1.get("velocity", "nan")),
                        actuator.valve_gain * actuator.current_limit / actuator.area)


def test_the_payload_is_a_fixed_link_and_names_do_not_clash() -> None:
    root = ET.fromstring(ml.to_urdf(SPECS["edges"]))
    fixed = [j for j in root.findall("joint") if j.get("type") == "fixed"]
    assert [j.get("name") for j in fixed] == ["end_effector_fixed_"]  # a spec joint has the name
    erector = ET.fromstring(ml.to_urdf(SPECS["erector"]))
    mass = erector.find("link[@name='end_effector']/inertial/mass")
    assert mass is not None and float(mass.get("value", "nan")) == 4000.0


def test_the_payload_link_carries_its_centre_of_gravity_and_inertia() -> None:
    """The end effector's ``com`` and ``inertia`` are its link's inertial origin and inertia
    (before, issue 33: a point mass at the link's origin, zero inertia)."""
    root = ET.fromstring(ml.to_urdf(GRAPPLE_OFF_AXIS))
    inertial = root.find("link[@name='end_effector']/inertial")
    assert inertial is not None
    origin, inertia = inertial.find("origin"), inertial.find("inertia")
    assert origin is not None and inertia is not None
    assert [float(x) for x in origin.get("xyz", "").split()] == [0.06, -0.04, -0.45]
    keys = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
    assert [float(inertia.get(k, "nan")) for k in keys] == [8.0, 12.0, 9.0, 0.4, -0.3, 0.2]


def test_unwritable_plugin_parameters_fail_naming_the_joint(monkeypatch) -> None:
    from maniplab import urdf

    real = urdf.actuator_dict
    monkeypatch.setattr(urdf, "actuator_dict",
                        lambda a: {**real(a), "table": [{"x": 1.0}]})
    with pytest.raises(ml.ManiplabError, match=r"^planar2\.yaml: joint q1, actuator\.table: list "):
        ml.to_urdf(SPECS["planar2"])


def test_cli_writes_the_urdf(capsys, tmp_path: Path) -> None:
    target = tmp_path / "erector.txt"
    result = subprocess.run([sys.executable, "-m", "maniplab", "export", "erector", "-f", "urdf",
                             "-o", str(target)], capture_output=True, text=True, cwd=tmp_path,
                            check=False)
    assert result.returncode == 0, result.stderr
    assert str(target) in result.stdout and "urdf" in result.stdout
    assert target.read_text(encoding="utf-8") == ml.to_urdf("erector")
    by_suffix = tmp_path / "arm.urdf"
    assert run_cli(capsys, "export", "planar2", "-o", str(by_suffix))[0] == 0
    assert ET.parse(by_suffix).getroot().tag == "robot"
    mjcf = tmp_path / "arm.xml"
    assert run_cli(capsys, "export", "planar2", "-o", str(mjcf))[0] == 0
    assert ET.parse(mjcf).getroot().tag == "mujoco"


def test_cli_refuses_an_unknown_format(capsys, tmp_path: Path) -> None:
    target = tmp_path / "arm.sdf"
    code, out, err = run_cli(capsys, "export", "erector", "-f", "sdf", "-o", str(target))
    assert code == 2 and out == "" and not target.exists()
    assert err.count("\n") == 1 and "invalid choice: 'sdf'" in err and "urdf" in err
