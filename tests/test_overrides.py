"""spec.with_overrides: dotted paths, joints by name or index, re-derived body defaults, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import maniplab as ml


@pytest.fixture(scope="module")
def planar2() -> ml.ManipulatorSpec:
    return ml.builtin_spec("planar2")  # two 1 kg, 1 m rods with default COG and inertia


@pytest.fixture(scope="module")
def erector() -> ml.ManipulatorSpec:
    return ml.builtin_spec("erector")


def override_error(spec, overrides) -> ml.SpecError:
    with pytest.raises(ml.SpecError) as info:
        spec.with_overrides(overrides)
    return info.value


def test_top_level_and_nested_values(erector):
    spec = erector.with_overrides(
        {"end_effector.mass": 800.0, "joints.q2.actuator.leakage": 1e-11, "gravity": [0, 0, -1.62]}
    )
    assert spec.end_effector.mass == 800.0
    assert spec.joint("q2").actuator.leakage == 1e-11
    assert spec.gravity == (0.0, 0.0, -1.62)
    assert erector.end_effector.mass == 4000.0  # the original is untouched
    assert erector.joint("q2").actuator.leakage == 1e-12


def test_everything_else_is_unchanged(erector):
    spec = erector.with_overrides({"joints.q5.friction.viscous": 123.0})
    assert spec.joint("q5").friction.viscous == 123.0
    assert spec.with_overrides({"joints.q5.friction.viscous": 500.0}) == erector


def test_joint_by_name_or_index_is_the_same(planar2):
    by_name = planar2.with_overrides({"joints.q2.body.mass": 3.0})
    by_index = planar2.with_overrides({"joints.1.body.mass": 3.0})
    by_negative_index = planar2.with_overrides({"joints.-1.body.mass": 3.0})
    assert by_name == by_index == by_negative_index
    assert by_name.joints[1].body.mass == 3.0
    assert by_name.joints[0].body.mass == 1.0


def test_source_is_kept(erector):
    assert erector.with_overrides({"name": "other"}).source == erector.source


def test_no_overrides_is_the_same_spec(erector):
    assert erector.with_overrides({}) == erector


# --- derived defaults follow length and mass; explicit values stay -------------------------------


def test_new_mass_and_length_re_derive_rod_inertia_and_com(planar2):
    spec = planar2.with_overrides({"joints.q2.body.mass": 3.0, "joints.q2.body.length": 2.0})
    body = spec.joint("q2").body
    rod = 3.0 * 2.0**2 / 12.0  # m L² / 12 = 1.0 about the two axes across the rod
    assert body.inertia == pytest.approx((0.0, rod, rod, 0.0, 0.0, 0.0))
    assert body.com == pytest.approx((1.0, 0.0, 0.0))
    assert spec.joint("q2").offset == pytest.approx([2.0, 0.0, 0.0])


def test_new_direction_re_derives_inertia_and_com(planar2):
    body = planar2.with_overrides({"joints.q1.body.direction": [0, 0, 1]}).joint("q1").body
    rod = 1.0 / 12.0
    assert body.inertia == pytest.approx((rod, rod, 0.0, 0.0, 0.0, 0.0))
    assert body.com == pytest.approx((0.0, 0.0, 0.5))


def test_massless_override_zeroes_the_default_inertia(planar2):
    body = planar2.with_overrides({"joints.q1.body.mass": 0.0}).joint("q1").body
    assert body.inertia == (0.0,) * 6
    assert body.length == 1.0


def test_explicit_inertia_is_not_re_derived(erector):
    body = erector.with_overrides({"joints.q1.body.mass": 3000.0}).joint("q1").body
    assert body.mass == 3000.0
    assert body.inertia == (40.0, 301.25, 301.25, 0.0, 0.0, 0.0)  # as written in erector.yaml
    assert body.com == pytest.approx((0.75, 0.0, 0.0))  # default COG: follows the length


def test_com_and_inertia_can_be_overridden_and_then_stay(planar2):
    spec = planar2.with_overrides(
        {"joints.q1.body.com": [0.2, 0, 0], "joints.q1.body.inertia": [0.1, 0.2, 0.3, 0, 0, 0]}
    )
    body = spec.with_overrides({"joints.q1.body.length": 3.0}).joint("q1").body
    assert body.com == (0.2, 0.0, 0.0)
    assert body.inertia == (0.1, 0.2, 0.3, 0.0, 0.0, 0.0)
    assert body.length == 3.0


def test_a_body_can_be_added_to_a_joint_without_one(erector):
    assert erector.joint("q3").body is None
    body = erector.with_overrides(
        {"joints.q3.body.length": 0.6, "joints.q3.body.mass": 120.0}
    ).joint("q3").body
    assert (body.length, body.mass, body.direction) == (0.6, 120.0, (1.0, 0.0, 0.0))
    assert body.inertia[1] == pytest.approx(120.0 * 0.36 / 12.0)


def test_a_body_can_be_removed(planar2):
    assert planar2.with_overrides({"joints.q2.body": None}).joint("q2").body is None


def test_actuator_can_be_replaced_whole(planar2):
    hydraulic = {"type": "hydraulic", "area": 1e-3, "volume": 1e-3, "valve_gain": 1e-4,
                 "supply_pressure": 2e7}  # fmt: skip
    spec = planar2.with_overrides({"joints.q1.actuator": hydraulic, "joints.q1.actuator.leakage": 1e-11})
    assert spec.joint("q1").actuator.leakage == 1e-11
    assert spec.joint("q1").actuator.area == 1e-3


# --- plugin actuators ----------------------------------------------------------------------------

MOTOR = {"type": "plugins.dcmotor:GearedDCMotor", "resistance": 1.0, "inductance": 5e-3,
         "torque_constant": 0.05, "gear_ratio": 20.0}  # fmt: skip


@pytest.fixture(scope="module")
def motor_arm(planar2) -> ml.ManipulatorSpec:
    return planar2.with_overrides({"joints.q1.actuator": MOTOR})


def test_a_plugin_parameter_can_be_overridden(motor_arm):
    spec = motor_arm.with_overrides({"joints.q1.actuator.gear_ratio": 50,
                                     "joints.0.actuator.efficiency": 0.8})
    params = spec.joint("q1").actuator.params
    assert (params.gear_ratio, params.efficiency) == (50.0, 0.8)
    assert (params.resistance, params.torque_constant) == (1.0, 0.05)  # the rest is kept
    assert motor_arm.joint("q1").actuator.params.gear_ratio == 20.0
    assert spec.with_overrides({"joints.q1.actuator.gear_ratio": 20.0,
                                "joints.q1.actuator.efficiency": 1.0}) == motor_arm


def test_an_overridden_plugin_parameter_is_simulated(motor_arm):
    """The plant's motor has the overridden gear ratio: joint torque N K i."""
    run = ml.simulate(motor_arm, inputs={"q1": 12.0}, duration=0.02,
                      overrides={"joints.q1.actuator.gear_ratio": 40.0})
    assert run.meta["overrides"] == {"joints.q1.actuator.gear_ratio": 40.0}
    assert run["current"][-1, 0] > 1.0
    np.testing.assert_allclose(run["tau_act"][:, 0], 40.0 * 0.05 * run["current"][:, 0],
                               rtol=1e-12)


@pytest.mark.parametrize(
    "path, value, field, words",
    [
        ("joints.q1.actuator.gear", 50, "actuator.gear",
         ["unknown key 'gear'", "valid keys: type, resistance, inductance", "gear_ratio"]),
        ("joints.q1.actuator.gear_ration", 50, "actuator.gear_ration",
         ["did you mean 'gear_ratio'"]),
        ("joints.q1.actuator.leakage", 1e-11, "actuator.leakage",
         ["unknown key 'leakage'", "hydraulic actuator", "override the whole actuator"]),
        ("joints.q1.actuator.gear_ratio", -2.0, "actuator.gear_ratio",
         ["> 0", "after override joints.q1.actuator.gear_ratio=-2.0"]),
    ],
)
def test_bad_plugin_overrides_name_joint_and_field(motor_arm, path, value, field, words):
    error = override_error(motor_arm, {path: value})
    assert (error.joint, error.field) == ("q1", field)
    for word in words:
        assert word in error.problem, f"{word!r} not in {error.problem!r}"



# --- sections inside an actuator (a pinned cylinder's valve and cylinder) -------------------------


def _edited(spec: ml.ManipulatorSpec, joint: str, section: str, key: str, value) -> ml.ManipulatorSpec:
    """``spec`` with one field of an actuator's section changed in its dict: the reference the
    dotted path must agree with."""
    data = spec.to_dict()
    data["joints"][spec.joint_index(joint)]["actuator"][section][key] = value
    return type(spec).from_dict(data, source=spec.source)


@pytest.mark.parametrize("section, key, value", [("valve", "nominal_flow", 5.0e-4),
                                                 ("valve", "flow_ratio", 0.6),
                                                 ("cylinder", "bore", 0.11)])
def test_a_field_of_a_section_inside_an_actuator_can_be_overridden(section, key, value):
    spec = ml.builtin_spec("patu655")
    changed = spec.with_overrides({f"joints.lift.actuator.{section}.{key}": value})
    assert changed == _edited(spec, "lift", section, key, value)
    assert changed != spec


def test_an_overridden_valve_is_simulated():
    """Half the valve's nominal flow, through the override, runs as the spec whose valve was
    edited in its dict (the reference), and not as the original."""
    spec = ml.builtin_spec("patu655")
    path = "joints.lift.actuator.valve.nominal_flow"
    flow = spec.joint("lift").actuator.valve.nominal_flow
    kw = {"inputs": {"lift": 0.5}, "duration": 0.2, "initial": {"dP": "gravity"}}
    run = ml.simulate(spec, overrides={path: 0.5 * flow}, **kw)
    reference = ml.simulate(_edited(spec, "lift", "valve", "nominal_flow", 0.5 * flow), **kw)
    assert run.meta["overrides"] == {path: 0.5 * flow}
    np.testing.assert_array_equal(run["q"], reference["q"])
    assert not np.array_equal(run["q"], ml.simulate(spec, **kw)["q"])


@pytest.mark.parametrize(
    "path, value, field, words",
    [
        ("joints.lift.actuator.valve.nominal_flo", 1e-3, "actuator.valve.nominal_flo",
         ["unknown key 'nominal_flo'", "did you mean 'nominal_flow'", "flow_ratio"]),
        ("joints.lift.actuator.valve.nominal_flow", -1e-3, "actuator.valve.nominal_flow",
         ["> 0", "after override joints.lift.actuator.valve.nominal_flow="]),
        ("joints.lift.actuator.valve.tau.x", 1.0, "actuator.valve.tau.x",
         ["'tau' is a single value", "joints.lift.actuator.valve.tau"]),
        ("joints.lift.actuator.leakage.x", 1.0, "actuator.leakage.x",
         ["'leakage' is a single value"]),
    ],
)
def test_bad_overrides_inside_an_actuator_name_joint_and_field(path, value, field, words):
    error = override_error(ml.builtin_spec("patu655"), {path: value})
    assert (error.joint, error.field) == ("lift", field)
    for word in words:
        assert word in error.problem, f"{word!r} not in {error.problem!r}"

# --- bad overrides ------------------------------------------------------------------------------

BAD_PATHS = [
    # id, path, joint, field, words
    ("misspelt-leaf", "joints.q2.actuator.leakag", "q2", "actuator.leakag",
     ["override 'joints.q2.actuator.leakag'", "unknown key 'leakag'", "did you mean 'leakage'"]),
    ("misspelt-section", "joints.q2.bdy.mass", "q2", "bdy.mass",
     ["unknown key 'bdy'", "did you mean 'body'"]),
    ("misspelt-top", "end_efector.mass", None, "end_efector.mass",
     ["unknown key 'end_efector'", "did you mean 'end_effector'"]),
    ("unknown-joint-name", "joints.q7.body.mass", None, "joints.q7.body.mass",
     ["no joint 'q7'", "q1, q2, q3, q4, q5, q6"]),
    ("misspelt-joint-name", "joints.q22.body.mass", None, "joints.q22.body.mass",
     ["no joint 'q22'", "did you mean 'q2'"]),
    ("joint-index-out-of-range", "joints.6.body.mass", None, "joints.6.body.mass",
     ["no joint 6", "0..5"]),
    ("whole-joint", "joints.q1", None, "joints.q1", ["whole joint", "joints.q1.body.mass"]),
    ("into-a-vector", "gravity.2", None, "gravity.2", ["single value", "{'gravity': ...}"]),
    ("into-limits", "joints.q1.limits.0", "q1", "limits.0", ["single value"]),
    ("empty-part", "joints..mass", None, "joints..mass", ["malformed path"]),
    ("source", "source", None, "source", ["unknown key 'source'"]),
]  # fmt: skip


@pytest.mark.parametrize(
    "path, joint, field, words", [c[1:] for c in BAD_PATHS], ids=[c[0] for c in BAD_PATHS]
)
def test_path_that_does_not_exist(erector, path, joint, field, words):
    error = override_error(erector, {path: 1.0})
    assert (error.file, error.joint, error.field) == (erector.source, joint, field)
    for word in words:
        assert word in error.problem, f"{word!r} not in {error.problem!r}"


def test_hydraulic_key_on_a_torque_actuator(planar2):
    error = override_error(planar2, {"joints.q1.actuator.leakage": 1e-11})
    assert (error.joint, error.field) == ("q1", "actuator.leakage")
    for word in ["unknown key 'leakage'", "hydraulic actuator", "'torque'"]:
        assert word in error.problem


def test_changing_the_actuator_type_asks_for_its_parameters(planar2):
    error = override_error(planar2, {"joints.q1.actuator.type": "hydraulic"})
    assert (error.joint, error.field) == ("q1", "actuator.area")
    assert "missing required key 'area'" in error.problem


@pytest.mark.parametrize(
    "path, value, joint, field, words",
    [
        ("end_effector.mass", -3.0, None, "end_effector.mass", [">= 0", "-3.0"]),
        ("end_effector.mass", "800 kg", None, "end_effector.mass", ["expected a number"]),
        ("joints.q2.body.direction", [1, 1, 0], "q2", "body.direction", ["unit vector"]),
        ("joints.q1.limits", [2, 1], "q1", "limits", ["not increasing"]),
        ("joints.q1.name", "q2", "q2", "name", ["duplicate joint name 'q2'"]),
        ("joints.q1.axis", "w", "q1", "axis", ["unknown axis 'w'"]),
        ("joints", [], None, "joints", ["at least one joint"]),
    ],
)
def test_invalid_value_is_reported_with_the_override(planar2, path, value, joint, field, words):
    error = override_error(planar2, {path: value})
    assert (error.file, error.joint, error.field) == (planar2.source, joint, field)
    for word in [*words, f"after override {path}="]:
        assert word in error.problem, f"{word!r} not in {error.problem!r}"


def test_overrides_must_be_a_mapping(planar2):
    error = override_error(planar2, [("end_effector.mass", 1.0)])
    assert "mapping" in error.problem


def test_non_text_path(planar2):
    error = override_error(planar2, {3: 1.0})
    assert "malformed path" in error.problem


# --- fuzzing: any override gives SpecError or a valid spec ---------------------------------------

PARTS = ["joints", "q1", "q2", "0", "1", "-1", "5", "body", "mass", "length", "direction", "com",
         "inertia", "actuator", "type", "limit", "leakage", "friction", "model", "coulomb",
         "end_effector", "size", "gravity", "name", "limits", "x", ""]  # fmt: skip
values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5)
    | st.sampled_from(["R", "P", "x", "hydraulic", "torque", "hybrid"]),
    lambda inner: st.lists(inner, max_size=6) | st.dictionaries(st.sampled_from(PARTS), inner, max_size=4),
    max_leaves=8,
)


@pytest.mark.filterwarnings("error")
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    overrides=st.dictionaries(
        st.lists(st.sampled_from(PARTS), min_size=1, max_size=5).map(".".join), values, max_size=3
    )
)
def test_fuzz_overrides(planar2, overrides):
    try:
        spec = planar2.with_overrides(overrides)
    except ml.SpecError as error:
        assert "\n" not in str(error)
        return
    assert ml.ManipulatorSpec.from_dict(spec.to_dict()) == spec


def test_the_pump_pressure_is_swept_with_its_cylinders() -> None:
    """``supply.pressure`` alone moves every pinned cylinder's supply pressure with it (they must
    equal it); a cylinder's own supply pressure given too must still match it."""
    spec = ml.resolve_spec(str(Path(__file__).parent / "arms" / "mixed" / "forestry_pump.yaml"))
    swept = spec.with_overrides({"supply.pressure": 9.0e6})
    pinned = [j for j in swept.joints if getattr(j.actuator, "cylinder", None)]
    assert swept.supply.pressure == 9.0e6 and len(pinned) == 2
    assert all(j.actuator.supply_pressure == 9.0e6 for j in pinned)
    lumped = [j for j in swept.joints if not getattr(j.actuator, "cylinder", None)
              and getattr(j.actuator, "supply_pressure", None) is not None]
    assert all(j.actuator.supply_pressure == spec.joint(j.name).actuator.supply_pressure
               for j in lumped)
    with pytest.raises(ml.SpecError, match="differs from the shared supply"):
        spec.with_overrides({"supply.pressure": 9.0e6, "joints.lift.actuator.supply_pressure": 8e6})
