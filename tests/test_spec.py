"""The spec dataclasses: defaults, physical checks, the paper's vocabulary, and to_dict/dump/load."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import maniplab as ml
from maniplab.spec import inertia_matrix

J = {"name": "q1", "type": "R", "axis": "z"}


def spec_of(**joint) -> ml.ManipulatorSpec:
    return ml.ManipulatorSpec.from_dict({"name": "t", "joints": [{**J, **joint}]})


def error_of(data) -> ml.SpecError:
    with pytest.raises(ml.SpecError) as info:
        ml.ManipulatorSpec.from_dict(data)
    return info.value


# --- defaults (the table in spec.py's docstring) ------------------------------------------------


def test_defaults_of_a_minimal_spec():
    spec = ml.ManipulatorSpec.from_dict({"joints": [{"type": "R", "axis": "z"}]})
    assert spec.name == "manipulator"
    assert spec.gravity == (0.0, 0.0, -9.81)
    joint = spec.joints[0]
    assert joint.name == "q1"
    assert joint.limits is None
    assert joint.body is None
    assert joint.actuator == ml.TorqueActuator(type="torque", limit=None)
    assert joint.friction.model is ml.FrictionModel.none
    assert spec.end_effector.mass == 0.0
    assert spec.end_effector.offset == (0.0, 0.0, 0.0)
    assert spec.end_effector.size is None
    assert spec.source is None


def test_friction_defaults():
    f = ml.Friction()
    assert (f.coulomb, f.static, f.viscous) == (0.0, 0.0, 0.0)
    assert (f.stribeck_velocity, f.stick_velocity) == (0.01, 1e-3)
    assert (f.sigma0, f.sigma1) == (1e5, 316.2)


def test_hydraulic_defaults_and_required_keys():
    a = ml.HydraulicActuator(type="hydraulic", area=1e-3, volume=2e-3, valve_gain=5e-4,
                             supply_pressure=2e7)  # fmt: skip
    assert (a.bulk_modulus, a.leakage, a.valve_tau, a.current_limit) == (1.4e9, 0.0, 0.01, 1.0)
    error = error_of({"joints": [{**J, "actuator": {"type": "hydraulic", "area": 1.0}}]})
    assert (error.joint, error.field) == ("q1", "actuator.volume")
    assert "missing required key 'volume'" in error.problem


def test_body_defaults_are_a_massless_zero_length_body_along_x():
    body = ml.Body()
    assert (body.length, body.direction, body.mass) == (0.0, (1.0, 0.0, 0.0), 0.0)
    assert body.com == (0.0, 0.0, 0.0)
    assert body.inertia == (0.0,) * 6


def test_default_com_is_the_middle_of_the_body():
    body = ml.Body(length=2.0, direction=(0.0, 0.6, 0.8), mass=3.0)
    assert body.com == pytest.approx((0.0, 0.6, 0.8))
    assert body.offset == pytest.approx([0.0, 1.2, 1.6])


@pytest.mark.parametrize(
    "direction, moments",  # a slender rod: m L²/12 about both axes across it, 0 along it
    [((1, 0, 0), (0, 1, 1)), ((0, 1, 0), (1, 0, 1)), ((0, 0, 1), (1, 1, 0))],
)
def test_default_inertia_is_a_slender_rod(direction, moments):
    m, length = 6.0, 2.0  # m L²/12 = 2
    body = ml.Body(length=length, direction=direction, mass=m)
    assert body.inertia == pytest.approx((*(2.0 * k for k in moments), 0.0, 0.0, 0.0))


def test_default_inertia_of_an_oblique_rod():
    # rod along e = (1, 1, 0)/sqrt(2): about z (across it) m L²/12; Ixy = -m L²/12 * e_x e_y
    body = ml.Body(length=1.0, direction=(math.sqrt(0.5), math.sqrt(0.5), 0.0), mass=12.0)
    ixx, iyy, izz, ixy, ixz, iyz = body.inertia
    assert izz == pytest.approx(1.0)
    assert (ixx, iyy, ixy) == pytest.approx((0.5, 0.5, -0.5))
    assert (ixz, iyz) == pytest.approx((0.0, 0.0))


def test_massless_body_has_no_inertia_but_keeps_its_length():
    body = ml.Body(length=1.5, mass=0.0)
    assert body.inertia == (0.0,) * 6
    assert body.offset == pytest.approx([1.5, 0.0, 0.0])


def test_no_body_means_no_offset():
    joint = spec_of().joints[0]
    assert joint.body is None
    assert joint.offset.tolist() == [0.0, 0.0, 0.0]


def test_explicit_com_and_inertia_are_kept():
    body = ml.Body(length=1.0, mass=2.0, com=(0.1, 0.2, 0.3), inertia=(1, 2, 2.5, 0.1, 0, 0))
    assert body.com == (0.1, 0.2, 0.3)
    assert body.inertia == (1.0, 2.0, 2.5, 0.1, 0.0, 0.0)


def test_end_effector_box_defaults_to_a_concrete_cube():
    assert ml.EndEffector(mass=2400.0).box_size == pytest.approx([1.0, 1.0, 1.0])
    assert ml.EndEffector(mass=0.0).box_size == pytest.approx([0.05] * 3)
    assert ml.EndEffector(mass=1.0, size=(1, 2, 3)).box_size.tolist() == [1.0, 2.0, 3.0]


# --- the paper's vocabulary ---------------------------------------------------------------------


def test_tr_is_a_prismatic_joint():
    joint = spec_of(type="Tr").joints[0]
    assert joint.type is ml.JointType.P
    assert joint.prismatic


def test_axis_vectors():
    assert ml.Axis.x.vector.tolist() == [1.0, 0.0, 0.0]
    assert ml.Axis.y.vector.tolist() == [0.0, 1.0, 0.0]
    assert spec_of(axis="z").joints[0].axis_vector.tolist() == [0.0, 0.0, 1.0]


# --- values: frozen, typed ----------------------------------------------------------------------


def test_specs_are_frozen():
    spec = spec_of()
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.name = "other"  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.joints[0].axis = ml.Axis.x  # type: ignore[misc]


def test_source_is_not_part_of_the_value():
    a = ml.ManipulatorSpec.from_dict({"joints": [J]}, source="a.yaml")
    b = ml.ManipulatorSpec.from_dict({"joints": [J]}, source="b.yaml")
    assert a == b
    assert a.source == "a.yaml"


def test_true_is_not_a_number():
    error = error_of({"joints": [{**J, "body": {"mass": True}}]})
    assert (error.joint, error.field) == ("q1", "body.mass")
    assert "expected a number, got true" in error.problem


@pytest.mark.parametrize("value", [10, np.float64(10.0), np.int64(10), np.float32(10.0)])
def test_ints_and_numpy_scalars_are_floats(value):
    mass = spec_of(body={"mass": value}).joints[0].body.mass
    assert type(mass) is float
    assert mass == 10.0


def test_numpy_arrays_are_vectors():
    body = spec_of(body={"direction": np.array([0.0, 0.0, 1.0])}).joints[0].body
    assert body.direction == (0.0, 0.0, 1.0)


def test_a_set_is_not_a_limits_pair():
    error = error_of({"joints": [{**J, "limits": {1.0, 2.0}}]})
    assert (error.joint, error.field) == ("q1", "limits")
    assert "expected a list of 2 numbers" in error.problem


def test_an_integer_too_large_for_a_float():
    error = error_of({"joints": [{**J, "body": {"mass": 10**400}}]})
    assert error.field == "body.mass"
    assert "expected a finite number" in error.problem


def test_a_body_whose_model_would_overflow_is_refused():
    """m l² of the default inertia (and every product the model forms) stays finite: lengths and
    masses beyond 1e18 are refused, naming the field."""
    error = error_of({"joints": [{**J, "body": {"length": 1e200, "mass": 1e200}}]})
    assert (error.joint, error.field) == ("q1", "body.length")
    assert_words(error.problem, ["1e+200", "beyond ±1e18", "overflow"])


def test_a_derived_inertia_beyond_the_bounds_is_refused_so_every_spec_reads_back():
    """Length and mass within ±1e18 can still derive m L²/12 beyond it; the spec is written out
    with its derived inertia, which must read back, so the body is refused naming it."""
    error = error_of({"joints": [{**J, "body": {"length": 1e18, "mass": 1.0}}]})
    assert (error.joint, error.field) == ("q1", "body")
    assert_words(error.problem, ["m L²/12", "beyond ±1e+18", "explicit inertia"])
    spec = spec_of(body={"length": 1e9, "mass": 1e-3})  # 8.3e13 kg·m²: within, and reads back
    assert ml.ManipulatorSpec.from_dict(spec.to_dict()) == spec


def assert_words(message, words):
    for word in words:
        assert word in message, f"{word!r} not in {message!r}"


# --- physical checks ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "inertia",
    [
        (1.0, 2.0, 3.0, 0.0, 0.0, 0.0),  # 1 + 2 >= 3: a thin plate, the limiting case
        (2.0, 2.0, 2.0, 0.5, -0.5, 0.5),  # a rotated box
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),  # a point mass
        (0.0, 1.0, 1.0, 0.0, 0.0, 0.0),  # a rod along x
    ],
)
def test_physical_inertias_are_accepted(inertia):
    body = spec_of(body={"mass": 1.0, "inertia": list(inertia)}).joints[0].body
    assert body.inertia == inertia


@pytest.mark.parametrize(
    "inertia, words",
    [
        ((1.0, 1.0, 3.0, 0.0, 0.0, 0.0), ["triangle inequality"]),  # 1 + 1 < 3
        ((1.0, 1.0, 1.0, 2.0, 0.0, 0.0), ["not positive semi-definite", "-1"]),  # eig 1-2 = -1
        ((1.0, -1e-3, 1.0, 0.0, 0.0, 0.0), ["negative moment"]),
        ((1e300, 1e300, 3e300, 0.0, 0.0, 0.0), ["beyond ±1e18"]),  # never squared
    ],
)
def test_unphysical_inertias_are_rejected(inertia, words):
    error = error_of({"joints": [{**J, "body": {"mass": 1.0, "inertia": list(inertia)}}]})
    assert error.joint == "q1" and error.field.startswith("body.inertia")  # [k]: one element
    assert_words(error.problem, words)


def test_rotated_inertia_matrix_layout():
    # fullinertia order [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]
    assert inertia_matrix((1, 2, 3, 4, 5, 6)).tolist() == [[1, 4, 5], [4, 2, 6], [5, 6, 3]]


@pytest.mark.parametrize(
    "direction, expected",
    [([1.0005, 0, 0], (1.0, 0.0, 0.0)), ([0, 0.6, 0.8008], (0.0, 0.6 / 1.0006, 0.8008 / 1.0006))],
)
def test_direction_within_1e_minus_3_of_unit_is_normalised(direction, expected):
    body = spec_of(body={"direction": direction}).joints[0].body
    assert body.direction == pytest.approx(expected, rel=1e-4, abs=1e-12)
    assert math.hypot(*body.direction) == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize(
    "direction, words",
    [([0, 0, 0], ["zero"]), ([1.0011, 0, 0], ["length 1.001", "unit vector"]),
     ([1e-200, 0, 0], ["unit vector"]), ([1e308, 1e308, 0], ["beyond ±1e18"])],
)  # fmt: skip
def test_zero_or_non_unit_direction_is_rejected(direction, words):
    error = error_of({"joints": [{**J, "body": {"direction": direction}}]})
    assert error.joint == "q1" and error.field.startswith("body.direction")
    assert_words(error.problem, words)


def test_duplicate_joint_names():
    error = error_of({"joints": [J, {**J, "type": "P"}]})
    assert (error.joint, error.field) == ("q1", "name")
    assert "duplicate joint name 'q1'" in error.problem


@pytest.mark.parametrize("name", ["two\nlines", "bell\x07", ""])
def test_spec_name_is_one_line_of_text(name):
    error = error_of({"name": name, "joints": [J]})
    assert (error.joint, error.field) == (None, "name")
    assert "expected" in error.problem
    assert "\n" not in str(error)


def test_empty_joint_list():
    error = error_of({"name": "t", "joints": []})
    assert (error.joint, error.field) == (None, "joints")
    assert "at least one joint" in error.problem


def test_not_a_mapping():
    error = error_of([J])
    assert (error.file, error.joint, error.field) == (None, None, None)
    assert_words(error.problem, ["expected a mapping", "joints"])


# --- constructing dataclasses directly also raises SpecError ------------------------------------


@pytest.mark.parametrize(
    "make, field, words",
    [
        (lambda: ml.Body(mass=-1.0), "mass", [">= 0"]),
        (lambda: ml.Body(direction=(0.0, 0.0, 0.0)), "direction", ["zero"]),
        (lambda: ml.Joint(name="q1", type="X", axis="z"), "type", ["unknown joint type 'X'"]),
        (lambda: ml.Joint(name="q1", type="R", axis="z", limits=(1.0, 0.0)), "limits",
         ["not increasing"]),
        (lambda: ml.Friction(model="stiction"), "model", ["unknown friction model"]),
        (lambda: ml.EndEffector(mass=True), "mass", ["expected a number"]),
        (lambda: ml.TorqueActuator(limit=0.0), "limit", ["> 0"]),
        (lambda: ml.TorqueActuator(type="electric"), "type", ["expected 'torque'", "'electric'"]),
        (lambda: ml.ManipulatorSpec(name="a", joints=[]), "joints", ["at least one joint"]),
    ],
)  # fmt: skip
def test_direct_construction_raises_spec_error(make, field, words):
    with pytest.raises(ml.SpecError) as info:
        make()
    assert info.value.field == field
    assert_words(info.value.problem, words)


# --- joint lookup -------------------------------------------------------------------------------


def test_joint_by_name_or_index():
    spec = ml.builtin_spec("crane3")
    assert spec.n == 3
    assert spec.joint("luff") is spec.joints[1]
    assert spec.joint(1) is spec.joints[1]
    assert spec.joint(-1).name == "telescope"
    assert spec.joint_index("telescope") == 2


@pytest.mark.parametrize("key", ["boom", 3, -4])
def test_unknown_joint_lists_the_names(key):
    with pytest.raises(ml.SpecError) as info:
        ml.builtin_spec("crane3").joint(key)
    assert_words(info.value.problem, ["no joint", "slew, luff, telescope", "0..2"])


# --- round trips: to_dict/from_dict and dump/load ------------------------------------------------

finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
nonneg = st.just(0.0) | st.floats(1e-18, 1e6)  # a spec's smallest positive value is 1e-18
positive = st.floats(1e-9, 1e9)
vec3 = st.tuples(finite, finite, finite)


@st.composite
def directions(draw):
    v = draw(st.tuples(finite, finite, finite).filter(lambda v: math.hypot(*v) > 1e-3))
    norm = math.hypot(*v) * draw(st.floats(1 - 9e-4, 1 + 9e-4))  # within the 1e-3 tolerance
    return [c / norm for c in v]


@st.composite
def inertias(draw):
    # a rigid body's inertia: tr(S) 1 - S for a second-moment matrix S = B Bᵀ
    b = np.array(draw(st.lists(st.floats(-10, 10), min_size=9, max_size=9))).reshape(3, 3)
    s = b @ b.T
    i = np.trace(s) * np.eye(3) - s
    return [float(i[0, 0]), float(i[1, 1]), float(i[2, 2]), float(i[0, 1]), float(i[0, 2]),
            float(i[1, 2])]  # fmt: skip


bodies = st.fixed_dictionaries(
    {},
    optional={"length": nonneg, "direction": directions(), "mass": nonneg, "com": vec3,
              "inertia": inertias()},
)  # fmt: skip
actuators = st.one_of(
    st.fixed_dictionaries({"type": st.just("torque")}, optional={"limit": positive}),
    st.fixed_dictionaries(
        {"type": st.just("hydraulic"), "area": positive, "volume": positive,
         "valve_gain": positive, "supply_pressure": positive},
        optional={"bulk_modulus": positive, "leakage": nonneg, "valve_tau": positive,
                  "current_limit": positive},
    ),
)  # fmt: skip
frictions = st.fixed_dictionaries(
    {"model": st.sampled_from(["none", "hybrid", "lugre"])},
    optional={"coulomb": nonneg, "static": nonneg, "stribeck_velocity": positive,
              "viscous": nonneg, "stick_velocity": positive, "sigma0": positive, "sigma1": nonneg},
)  # fmt: skip
limits = st.lists(finite, min_size=2, max_size=2, unique=True).map(sorted)
names = st.from_regex(r"[A-Za-z_][A-Za-z0-9_\-]{0,7}", fullmatch=True)


@st.composite
def spec_dicts(draw):
    joint_names = draw(st.lists(names, min_size=1, max_size=4, unique=True))
    joints = [
        draw(st.fixed_dictionaries(
            {"name": st.just(name), "type": st.sampled_from(["R", "P", "Tr"]),
             "axis": st.sampled_from("xyz")},
            optional={"limits": limits, "body": st.none() | bodies, "actuator": actuators,
                      "friction": frictions},
        ))
        for name in joint_names
    ]  # fmt: skip
    return draw(st.fixed_dictionaries(
        {"joints": st.just(joints)},
        optional={"name": st.text(min_size=1, max_size=12).filter(str.isprintable),
                  "gravity": vec3,
                  "end_effector": st.fixed_dictionaries({}, optional={
                      "mass": nonneg, "offset": vec3, "size": st.none() | st.tuples(
                          positive, positive, positive)})},
    ))  # fmt: skip


ROUND_TRIP = settings(max_examples=150, deadline=None,
                      suppress_health_check=[HealthCheck.too_slow])  # fmt: skip


@ROUND_TRIP
@given(data=spec_dicts())
def test_random_valid_specs_round_trip_through_dicts(data):
    spec = ml.ManipulatorSpec.from_dict(data)
    assert ml.ManipulatorSpec.from_dict(spec.to_dict()) == spec


@settings(ROUND_TRIP, max_examples=100)
@given(data=spec_dicts())
def test_random_valid_specs_round_trip_through_yaml(tmp_path_factory, data):
    spec = ml.ManipulatorSpec.from_dict(data)
    path = tmp_path_factory.getbasetemp() / "round.yaml"
    spec.dump(path)
    assert ml.load_spec(path) == spec


@pytest.mark.parametrize("name", ["erector", "planar2", "crane3"])
def test_builtin_specs_round_trip_through_yaml(tmp_path, name):
    spec = ml.builtin_spec(name)
    spec.dump(tmp_path / "copy.yaml")
    again = ml.load_spec(tmp_path / "copy.yaml")
    assert again == spec
    assert again.to_dict() == spec.to_dict()


def test_to_dict_is_plain_data():
    data = ml.builtin_spec("erector").to_dict()

    def check(value):
        if isinstance(value, dict):
            assert all(isinstance(k, str) for k in value)
            for v in value.values():
                check(v)
        elif isinstance(value, list):
            for v in value:
                check(v)
        else:
            assert value is None or type(value) in (str, float, int, bool), repr(value)

    check(data)
    assert data["joints"][3]["type"] == "P"
    assert data["joints"][0]["friction"]["model"] == "hybrid"
