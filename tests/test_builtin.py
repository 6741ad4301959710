"""The built-in specs (the paper's erector, a textbook planar arm, a crane) and resolve_spec."""

from __future__ import annotations

import pytest

import maniplab as ml


def test_builtin_names():
    assert ml.builtin_specs() == ["crane3", "erector", "erector_pinned", "excavator", "patu655", "planar2"]


@pytest.mark.parametrize("name", ["crane3", "erector", "erector_pinned", "excavator", "patu655", "planar2"])
def test_each_builtin_loads_under_its_name(name):
    spec = ml.builtin_spec(name)
    assert spec.name == name
    assert spec.source.endswith(f"{name}.yaml")


def test_unknown_builtin_lists_the_names():
    with pytest.raises(ml.SpecError) as info:
        ml.builtin_spec("erecter")
    assert "no built-in spec 'erecter'" in info.value.problem
    assert "crane3, erector, erector_pinned, excavator, patu655, planar2" in info.value.problem
    assert "did you mean 'erector'" in info.value.problem


# --- erector: the paper's Table 2 ----------------------------------------------------------------


@pytest.fixture(scope="module")
def erector() -> ml.ManipulatorSpec:
    return ml.builtin_spec("erector")


def test_erector_axes_and_types_follow_table_2(erector):
    assert [j.axis.value for j in erector.joints] == ["z", "z", "z", "z", "y", "x"]
    assert [j.type.value for j in erector.joints] == ["R", "R", "R", "P", "R", "R"]  # Tr = P


def test_erector_has_bodies_on_joints_1_2_and_6_along_x(erector):
    with_body = [i + 1 for i, j in enumerate(erector.joints) if j.body is not None]
    assert with_body == [1, 2, 6]
    for i in (0, 1, 5):
        body = erector.joints[i].body
        assert body.direction == (1.0, 0.0, 0.0)
        assert body.length > 0 and body.mass > 0


def test_erector_is_hydraulic_with_hybrid_friction(erector):
    for joint in erector.joints:
        assert isinstance(joint.actuator, ml.HydraulicActuator), joint.name
        assert joint.friction.model is ml.FrictionModel.hybrid, joint.name
        assert joint.limits is not None, joint.name


def test_erector_carries_a_concrete_segment_of_3_to_5_tonnes(erector):
    assert 3000.0 <= erector.end_effector.mass <= 5000.0


def test_erector_gravity_is_across_the_tunnel_axis(erector):
    # z is the tunnel axis, so q1..q3 (about z) lift against gravity
    assert erector.gravity[2] == 0.0
    assert abs(erector.gravity[1]) == pytest.approx(9.81)


@pytest.mark.parametrize("index", [0, 1, 5])
def test_erector_link_inertias_are_square_section_boxes(erector, index):
    # a box of length L along x and square section b x b: Ixx = m b²/6, Iyy = Izz = m (L² + b²)/12,
    # so Iyy = Ixx / 2 + m L²/12 whatever b is
    body = erector.joints[index].body
    ixx, iyy, izz, ixy, ixz, iyz = body.inertia
    assert iyy == izz
    assert iyy == pytest.approx(ixx / 2 + body.mass * body.length**2 / 12, rel=1e-4)
    assert (ixy, ixz, iyz) == (0.0, 0.0, 0.0)


def test_erector_actuators_are_sized_for_20_mpa(erector):
    for joint in erector.joints:
        assert joint.actuator.supply_pressure == 20.0e6
        assert 1e-13 <= joint.actuator.leakage <= 1e-11


# --- planar2: the textbook two-link arm ----------------------------------------------------------


def test_planar2_is_two_revolute_joints_about_z_with_torque_actuators():
    spec = ml.builtin_spec("planar2")
    assert spec.n == 2
    for joint in spec.joints:
        assert (joint.type, joint.axis) == (ml.JointType.R, ml.Axis.z)
        assert isinstance(joint.actuator, ml.TorqueActuator)
        assert joint.friction.model is ml.FrictionModel.none


def test_planar2_links_are_uniform_slender_rods():
    for joint in ml.builtin_spec("planar2").joints:
        body = joint.body
        assert (body.length, body.mass) == (1.0, 1.0)
        assert body.com == pytest.approx((0.5, 0.0, 0.0))
        assert body.inertia[2] == pytest.approx(1.0 / 12.0)  # m L²/12 about z


def test_crane3_is_slew_luff_telescope():
    spec = ml.builtin_spec("crane3")
    assert spec.joint_names == ("slew", "luff", "telescope")
    assert [(j.type.value, j.axis.value) for j in spec.joints] == [("R", "z"), ("R", "y"), ("P", "x")]


# --- resolve_spec --------------------------------------------------------------------------------


def test_resolve_a_builtin_name():
    assert ml.resolve_spec("planar2") == ml.builtin_spec("planar2")


def test_resolve_a_path(tmp_path):
    path = tmp_path / "arm.yaml"
    path.write_text("joints:\n  - {type: P, axis: y}\n")
    for given in (path, str(path)):
        spec = ml.resolve_spec(given)
        assert spec.name == "arm"
        assert spec.joints[0].type is ml.JointType.P


def test_resolve_a_spec_returns_it():
    spec = ml.builtin_spec("crane3")
    assert ml.resolve_spec(spec) is spec


def test_a_file_named_like_a_builtin_wins(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "erector").write_text("name: mine\njoints:\n  - {type: R, axis: x}\n")
    assert ml.resolve_spec("erector").name == "mine"


def test_resolve_neither_file_nor_builtin(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ml.SpecError) as info:
        ml.resolve_spec("planar3")
    error = info.value
    assert error.file == "planar3"
    for word in ["no such file and no built-in spec", "crane3, erector, erector_pinned, excavator, patu655, planar2",
                 "did you mean 'planar2'"]:  # fmt: skip
        assert word in error.problem


def test_resolve_a_missing_yaml_path(tmp_path):
    path = tmp_path / "arm.yaml"
    with pytest.raises(ml.SpecError) as info:
        ml.resolve_spec(path)
    assert info.value.file == str(path)
    assert "file not found" in info.value.problem


def test_resolve_something_that_is_not_a_spec():
    with pytest.raises(ml.SpecError) as info:
        ml.resolve_spec(42)  # type: ignore[arg-type]
    assert "expected a spec, a spec file or a built-in name" in info.value.problem
