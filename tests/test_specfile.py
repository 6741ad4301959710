"""Spec files as a user types them: loading, every kind of mistake, dump/load, and fuzzing.

Each bad-input case edits one line of a valid file (ARM below, whose line numbers the cases
refer to) and checks the SpecError's file, joint, field, line and the key words of its message.
"""

from __future__ import annotations

import copy
import math
import os
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import maniplab as ml
from maniplab.schema.translate import problem_text as _problem
from maniplab.spec.files import load_spec
from maniplab.spec.yaml_io import parse_yaml

ARM = """\
name: arm
gravity: [0, 0, -9.81]
joints:
  - name: q1
    type: R
    axis: z
    limits: [-1.5, 1.5]
    body:
      length: 1.0
      direction: [1, 0, 0]
      mass: 10.0
    actuator:
      type: hydraulic
      area: 0.001
      volume: 0.002
      valve_gain: 0.0005
      supply_pressure: 2.0e7
      leakage: 1e-11
    friction:
      model: hybrid
      coulomb: 100.0
  - name: q2
    type: Tr
    axis: x
end_effector:
  mass: 500.0
"""


def edited(old: str, new: str) -> str:
    """ARM with the one occurrence of ``old`` replaced by ``new``."""
    assert ARM.count(old) == 1, old
    return ARM.replace(old, new)


def write(tmp_path: Path, text: str | bytes, name: str = "arm.yaml") -> Path:
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


def load_error(path: Path) -> ml.SpecError:
    with pytest.raises(ml.SpecError) as info:
        load_spec(path)
    return info.value


def assert_words(message: str, words: list[str]) -> None:
    for word in words:
        assert word in message, f"{word!r} not in {message!r}"


# --- what loads ----------------------------------------------------------------------------------


def test_valid_file_loads_with_its_values(tmp_path):
    spec = load_spec(write(tmp_path, ARM))
    assert spec.name == "arm"
    assert spec.gravity == (0.0, 0.0, -9.81)
    assert spec.joint_names == ("q1", "q2")
    q1, q2 = spec.joints
    assert q1.limits == (-1.5, 1.5)
    assert q1.body.mass == 10.0
    assert q1.actuator.supply_pressure == 2.0e7
    assert q1.friction.model is ml.FrictionModel.hybrid
    assert q2.type is ml.JointType.P  # the paper's "Tr"
    assert q2.body is None
    assert spec.end_effector.mass == 500.0
    assert spec.source == str(tmp_path / "arm.yaml")


def test_leakage_1e_minus_11_is_a_float(tmp_path):
    # YAML 1.1 reads 1e-11 (no decimal point) as a string; maniplab reads it as a number.
    leakage = load_spec(write(tmp_path, ARM)).joints[0].actuator.leakage
    assert isinstance(leakage, float)
    assert leakage == 1e-11


@pytest.mark.parametrize(
    "text, value", [("1e5", 1e5), ("1E-3", 1e-3), ("+2e7", 2e7), ("-.5", -0.5), ("3.", 3.0)]
)
def test_exponent_and_signed_numbers_are_floats(text, value):
    data, _ = parse_yaml(f"x: {text}")
    assert isinstance(data["x"], float)
    assert data["x"] == value


def test_integers_are_accepted_as_floats(tmp_path):
    spec = load_spec(write(tmp_path, edited("mass: 10.0", "mass: 10")))
    assert spec.joints[0].body.mass == 10.0
    assert isinstance(spec.joints[0].body.mass, float)
    assert spec.gravity == (0.0, 0.0, -9.81)  # [0, 0, ...] in the file


@pytest.mark.parametrize(
    "written, expected",
    [("R", "R"), ("r", "R"), ("revolute", "R"), ("Rotational", "R"), ("hinge", "R"),
     ("P", "P"), ("Tr", "P"), ("TR", "P"), ("prismatic", "P"), ("slide", "P")],
)  # fmt: skip
def test_joint_type_vocabulary(tmp_path, written, expected):
    spec = load_spec(write(tmp_path, edited("type: R", f"type: {written}")))
    assert spec.joints[0].type.value == expected


def test_axis_in_capitals_is_accepted(tmp_path):
    spec = load_spec(write(tmp_path, edited("axis: z", "axis: Z")))
    assert spec.joints[0].axis is ml.Axis.z


def test_name_defaults_to_the_file_stem(tmp_path):
    spec = load_spec(write(tmp_path, edited("name: arm\n", ""), name="my-crane.yaml"))
    assert spec.name == "my-crane"


def test_joint_names_default_to_q1_to_qn(tmp_path):
    text = "joints:\n  - {type: R, axis: z}\n  - {type: P, axis: x}\n  - {type: R, axis: y}\n"
    assert load_spec(write(tmp_path, text)).joint_names == ("q1", "q2", "q3")


def test_nearly_unit_direction_is_normalised(tmp_path):
    spec = load_spec(write(tmp_path, edited("[1, 0, 0]", "[0, 0.6004, 0.8]")))
    direction = spec.joints[0].body.direction
    assert math.hypot(*direction) == pytest.approx(1.0, abs=1e-15)
    assert direction[1] / direction[2] == pytest.approx(0.6004 / 0.8, rel=1e-15)


def test_yaml_anchors_and_flow_style_are_plain_yaml(tmp_path):
    text = (
        "joints:\n"
        "  - {name: a, type: R, axis: z, friction: &f {model: hybrid, coulomb: 5.0}}\n"
        "  - {name: b, type: R, axis: z, friction: *f}\n"
    )
    spec = load_spec(write(tmp_path, text))
    assert spec.joints[0].friction == spec.joints[1].friction
    assert spec.joints[1].friction.coulomb == 5.0


# --- what does not load: one line typed wrong --------------------------------------------------

CASES = [
    # id, old, new, joint, field, line, words in the message
    ("unit-after-number", "mass: 10.0", "mass: 10 kg", "q1", "body.mass", 11,
     ["expected a number", "'10 kg'", "SI units"]),
    ("decimal-comma", "mass: 10.0", "mass: 1,5", "q1", "body.mass", 11,
     ["expected a number", "1.5"]),
    ("bool-for-number", "mass: 10.0", "mass: true", "q1", "body.mass", 11,
     ["expected a number", "true", "boolean"]),
    ("yes-for-number", "mass: 10.0", "mass: yes", "q1", "body.mass", 11,
     ["expected a number", "boolean"]),
    ("list-for-number", "mass: 10.0", "mass: [10]", "q1", "body.mass", 11,
     ["expected a number", "[10]"]),
    ("empty-number", "mass: 10.0", "mass:", "q1", "body.mass", 11,
     ["expected a number", "empty"]),
    ("nan", "mass: 10.0", "mass: .nan", "q1", "body.mass", 11, ["finite", "nan"]),
    ("inf", "length: 1.0", "length: .inf", "q1", "body.length", 9, ["finite", "inf"]),
    ("minus-inf-limit", "[-1.5, 1.5]", "[-.inf, 1.5]", "q1", "limits[0]", 7, ["finite"]),
    ("negative-mass", "mass: 10.0", "mass: -10.0", "q1", "body.mass", 11, [">= 0", "-10.0"]),
    ("negative-length", "length: 1.0", "length: -1.0", "q1", "body.length", 9, [">= 0"]),
    ("negative-friction", "coulomb: 100.0", "coulomb: -100.0", "q1", "friction.coulomb", 21,
     [">= 0"]),
    ("zero-area", "area: 0.001", "area: 0", "q1", "actuator.area", 14, ["> 0", "0"]),
    ("negative-inertia", "mass: 10.0", "mass: 10.0\n      inertia: [-1, 1, 1, 0, 0, 0]",
     "q1", "body.inertia", 12, ["negative moment", ">= 0"]),
    ("inertia-not-psd", "mass: 10.0", "mass: 10.0\n      inertia: [1, 1, 1, 2, 0, 0]",
     "q1", "body.inertia", 12, ["not positive semi-definite", "-1"]),
    ("inertia-triangle", "mass: 10.0", "mass: 10.0\n      inertia: [1, 1, 3, 0, 0, 0]",
     "q1", "body.inertia", 12, ["triangle inequality", "I1 + I2 >= I3"]),
    ("inertia-five", "mass: 10.0", "mass: 10.0\n      inertia: [1, 1, 1, 0, 0]",
     "q1", "body.inertia", 12, ["list of 6 numbers", "[1, 1, 1, 0, 0]"]),
    ("zero-direction", "[1, 0, 0]", "[0, 0, 0]", "q1", "body.direction", 10,
     ["zero", "unit vector"]),
    ("non-unit-direction", "[1, 0, 0]", "[1, 1, 0]", "q1", "body.direction", 10,
     ["length 1.414", "unit vector", "0.7071"]),
    ("slightly-long-direction", "[1, 0, 0]", "[1.002, 0, 0]", "q1", "body.direction", 10,
     ["unit vector"]),
    ("direction-two", "[1, 0, 0]", "[1, 0]", "q1", "body.direction", 10,
     ["expected a list of 3 numbers, got [1, 0]"]),
    ("direction-four", "[1, 0, 0]", "[1, 0, 0, 0]", "q1", "body.direction", 10,
     ["expected a list of 3 numbers", "[1, 0, 0, 0]"]),
    ("direction-axis-name", "[1, 0, 0]", "x", "q1", "body.direction", 10,
     ["list of 3 numbers", "'x'"]),
    ("direction-quoted", "[1, 0, 0]", '["1", "0", "0"]', "q1", "body.direction[0]", 10,
     ["expected a number", "'1'"]),
    ("limits-one", "[-1.5, 1.5]", "[1]", "q1", "limits", 7,
     ["expected a list of 2 numbers, got [1]"]),
    ("limits-three", "[-1.5, 1.5]", "[1, 2, 3]", "q1", "limits", 7, ["list of 2 numbers"]),
    ("limits-scalar", "[-1.5, 1.5]", "1.5", "q1", "limits", 7, ["list of 2 numbers", "1.5"]),
    ("limits-reversed", "[-1.5, 1.5]", "[1.5, -1.5]", "q1", "limits", 7,
     ["not increasing", "[lower, upper]"]),
    ("limits-equal", "[-1.5, 1.5]", "[1, 1]", "q1", "limits", 7, ["not increasing"]),
    ("gravity-two", "[0, 0, -9.81]", "[0, -9.81]", None, "gravity", 2,
     ["list of 3 numbers, got [0, -9.81]"]),
    ("gravity-word", "[0, 0, -9.81]", "down", None, "gravity", 2, ["list of 3 numbers"]),
    ("unknown-axis", "axis: z", "axis: w", "q1", "axis", 6,
     ["unknown axis 'w'", "'x', 'y' or 'z'"]),
    ("unknown-joint-type", "type: R", "type: rot", "q1", "type", 5,
     ["unknown joint type 'rot'", "'R' or 'P'", "Tr"]),
    ("numeric-joint-type", "type: R", "type: 1", "q1", "type", 5, ["unknown joint type", "'R'"]),
    ("unknown-actuator", "type: hydraulic", "type: electric", "q1", "actuator.type", 13,
     ["unknown actuator type 'electric'", "'torque', 'hydraulic' or 'passive'"]),
    ("actuator-capitalised", "type: hydraulic", "type: Hydraulic", "q1", "actuator.type", 13,
     ["unknown actuator type", "did you mean 'hydraulic'"]),
    ("actuator-without-type", "      type: hydraulic\n", "", "q1", "actuator.type", 12,
     ["missing key 'type'", "torque", "hydraulic"]),
    ("actuator-missing-area", "      area: 0.001\n", "", "q1", "actuator.area", 12,
     ["missing required key 'area'"]),
    ("actuator-misspelt-key", "area: 0.001", "aera: 0.001", "q1", "actuator.aera", 14,
     ["unknown key 'aera'", "did you mean 'area'", "valid keys"]),
    ("actuator-as-word", "axis: x", "axis: x\n    actuator: hydraulic", "q2", "actuator", 25,
     ["expected a mapping", "type: torque", "'hydraulic'"]),
    ("unknown-friction-model", "model: hybrid", "model: coulomb", "q1", "friction.model", 20,
     ["unknown friction model 'coulomb'", "'none', 'hybrid' or 'lugre'"]),
    ("friction-model-typo", "model: hybrid", "model: hybird", "q1", "friction.model", 20,
     ["did you mean 'hybrid'"]),
    ("friction-misspelt-key", "coulomb: 100.0", "columb: 100.0", "q1", "friction.columb", 21,
     ["unknown key 'columb'", "did you mean 'coulomb'"]),
    ("friction-as-word", "axis: x", "axis: x\n    friction: none", "q2", "friction", 25,
     ["expected a mapping", "model"]),
    ("body-misspelt-key", "mass: 10.0", "mas: 10.0", "q1", "body.mas", 11,
     ["unknown key 'mas'", "did you mean 'mass'"]),
    ("body-as-list", "axis: x", "axis: x\n    body: [1, 0, 0]", "q2", "body", 25,
     ["expected a mapping", "[1, 0, 0]"]),
    ("joint-misspelt-key", "axis: z", "axes: z", "q1", "axes", 6,
     ["unknown key 'axes'", "did you mean 'axis'"]),
    ("joint-missing-type", "    type: R\n", "", "q1", "type", 4, ["missing required key 'type'"]),
    ("joint-missing-axis", "    axis: x\n", "", "q2", "axis", 22, ["missing required key 'axis'"]),
    ("duplicate-joint-name", "name: q2", "name: q1", "q1", "name", 22,
     ["duplicate joint name 'q1'", "unique"]),
    ("joint-name-with-space", "name: q2", "name: joint 2", "joint 2", "name", 22,
     ["not a valid name", "letters"]),
    ("joint-name-number", "name: q2", "name: 7", "#2", "name", 22, ["expected text", "7"]),
    ("top-misspelt-key", "gravity:", "gravty:", None, "gravty", 2,
     ["unknown key 'gravty'", "did you mean 'gravity'"]),
    ("top-key-source", "gravity:", "source: x\ngravity:", None, "source", 2,
     ["unknown key 'source'"]),
    ("end-effector-number", "end_effector:\n  mass: 500.0", "end_effector: 500.0", None,
     "end_effector", 25, ["expected a mapping", "500.0"]),
    ("end-effector-size-negative", "mass: 500.0", "mass: 500.0\n  size: [1, -1, 1]", None,
     "end_effector.size[1]", 27, ["> 0", "-1"]),
    ("empty-name", "name: arm", "name: ''", None, "name", 1, ["non-empty name"]),
    # the end effector's inertia and centre of gravity (issue 33)
    ("ee-inertia-negative", "mass: 500.0", "mass: 500.0\n  inertia: [-1, 1, 1, 0, 0, 0]", None,
     "end_effector.inertia", 27, ["negative moment", ">= 0"]),
    ("ee-inertia-not-psd", "mass: 500.0", "mass: 500.0\n  inertia: [1, 1, 1, 2, 0, 0]", None,
     "end_effector.inertia", 27, ["not positive semi-definite", "-1"]),
    ("ee-inertia-triangle", "mass: 500.0", "mass: 500.0\n  inertia: [1, 1, 3, 0, 0, 0]", None,
     "end_effector.inertia", 27, ["triangle inequality", "I1 + I2 >= I3"]),
    ("ee-inertia-three", "mass: 500.0", "mass: 500.0\n  inertia: [8, 12, 9]", None,
     "end_effector.inertia", 27, ["list of 6 numbers", "[8, 12, 9]"]),
    ("ee-inertia-word", "mass: 500.0", "mass: 500.0\n  inertia: heavy", None,
     "end_effector.inertia", 27, ["list of 6 numbers", "'heavy'"]),
    ("ee-com-two", "mass: 500.0", "mass: 500.0\n  com: [0, -0.4]", None,
     "end_effector.com", 27, ["list of 3 numbers, got [0, -0.4]"]),
]  # fmt: skip


@pytest.mark.parametrize(
    "old, new, joint, field, line, words", [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
def test_bad_value_names_file_joint_field_and_line(tmp_path, old, new, joint, field, line, words):
    path = write(tmp_path, edited(old, new))
    error = load_error(path)
    assert (error.file, error.joint, error.field, error.line) == (str(path), joint, field, line)
    assert_words(error.problem, words)
    assert str(error).startswith(f"{path}:{line}, ")
    assert "\n" not in str(error)


WHOLE_FILE_CASES = [
    ("empty-joint-list", "name: arm\njoints: []\n", "joints", 2,
     ["joint list is empty", "at least one joint"]),
    ("no-joints", "name: arm\ngravity: [0, 0, -9.81]\n", "joints", 1,
     ["missing required key 'joints'"]),
    ("joints-as-mapping", "joints:\n  q1: {type: R, axis: z}\n", "joints", 1,
     ["list of joints", "mapping"]),
    ("top-level-list", "- name: q1\n  type: R\n  axis: z\n", None, None,
     ["expected a mapping with keys", "joints", "list"]),
    ("top-level-word", "erector\n", None, None, ["expected a mapping", "'erector'"]),
    ("number-as-key", "joints: [{type: R, axis: z}]\n1: 2\n", None, 1,
     ["unknown key 1", "joints"]),
]  # fmt: skip


@pytest.mark.parametrize(
    "text, field, line, words", [c[1:] for c in WHOLE_FILE_CASES], ids=[c[0] for c in WHOLE_FILE_CASES]
)
def test_bad_structure_names_file_field_and_line(tmp_path, text, field, line, words):
    path = write(tmp_path, text)
    error = load_error(path)
    assert (error.file, error.joint, error.field, error.line) == (str(path), None, field, line)
    assert_words(error.problem, words)


def test_a_joint_written_as_a_word_is_named_by_position(tmp_path):
    error = load_error(write(tmp_path, "joints:\n  - {type: R, axis: z}\n  - q2\n"))
    assert (error.joint, error.field, error.line) == ("#2", None, 3)
    assert_words(error.problem, ["expected a mapping", "name: q1, type: R, axis: z", "'q2'"])


def test_default_name_clash_says_which_joint_has_no_name(tmp_path):
    error = load_error(write(tmp_path, "joints:\n  - {name: q2, type: R, axis: z}\n"
                                       "  - {type: R, axis: z}\n"))  # fmt: skip
    assert (error.joint, error.field) == ("q2", "name")
    assert_words(error.problem, ["duplicate joint name 'q2'", "joint 2 has no name"])


def test_an_unforeseen_pydantic_error_still_gives_one_line():
    # _problem's last branch, for error kinds no spec input produces today
    error = {"type": "new_kind", "msg": "Input is odd", "input": "a\nb", "loc": ("x",)}
    problem = _problem(error, ("x",), [])
    assert problem == "Input is odd, got 'a\\nb' (text)"


# --- what is not YAML, or not a file ------------------------------------------------------------

YAML_CASES = [
    ("tab-indent", "    axis: z", "\taxis: z", 6, ["invalid YAML", "tab", "spaces"]),
    ("key-twice", "    axis: z", "    axis: z\n    axis: y", 7,
     ["invalid YAML", "'axis' is given twice"]),
    ("key-twice-nested", "mass: 10.0", "mass: 10.0\n      mass: 11.0", 12, ["'mass' is given twice"]),
    ("unclosed-bracket", "[-1.5, 1.5]", "[-1.5, 1.5", 8, ["invalid YAML", "line 7"]),
    ("over-indented", "    axis: z", "     axis: z", 6, ["invalid YAML", "indentation"]),
    ("under-indented", "    axis: z", "  axis: z", 6, ["invalid YAML", "indentation"]),
    ("undefined-alias", "mass: 500.0", "mass: *m", 26, ["invalid YAML", "alias"]),
    ("python-tag", "mass: 500.0", "mass: !!python/object:os.system ls", 26, ["invalid YAML"]),
]  # fmt: skip


@pytest.mark.parametrize(
    "old, new, line, words", [c[1:] for c in YAML_CASES], ids=[c[0] for c in YAML_CASES]
)
def test_yaml_error_names_file_and_line(tmp_path, old, new, line, words):
    path = write(tmp_path, edited(old, new))
    error = load_error(path)
    assert (error.file, error.joint, error.field, error.line) == (str(path), None, None, line)
    assert_words(error.problem, words)
    assert "\n" not in str(error)


def test_missing_file(tmp_path):
    path = tmp_path / "nope.yaml"
    error = load_error(path)
    assert (error.file, error.joint, error.field, error.line) == (str(path), None, None, None)
    assert "file not found" in error.problem


def test_directory(tmp_path):
    error = load_error(tmp_path)
    assert error.file == str(tmp_path)
    assert "is a directory" in error.problem


@pytest.mark.parametrize("text", ["", "\n\n", "# only a comment\n", "---\n"])
def test_empty_file(tmp_path, text):
    path = write(tmp_path, text)
    error = load_error(path)
    assert error.file == str(path)
    assert_words(error.problem, ["empty", "joints"])


def test_file_that_is_not_utf8(tmp_path):
    path = write(tmp_path, b"name: \xff\xfe\n")
    error = load_error(path)
    assert error.file == str(path)
    assert "cannot be read" in error.problem


def test_nul_byte_in_path():
    error = load_error("arm\0.yaml")
    assert error.file == "arm\0.yaml"
    assert "not found" in error.problem or "not a usable file name" in error.problem


def test_deeply_nested_yaml(tmp_path):
    error = load_error(write(tmp_path, "joints: " + "[" * 1000 + "]" * 1000 + "\n"))
    assert "invalid YAML" in error.problem or "expected" in error.problem


def test_spec_error_is_a_maniplab_error_and_a_value_error(tmp_path):
    error = load_error(tmp_path / "nope.yaml")
    assert isinstance(error, ml.ManiplabError)
    assert isinstance(error, ValueError)


# --- dump ---------------------------------------------------------------------------------------


def test_dump_then_load_is_equal(tmp_path):
    spec = load_spec(write(tmp_path, ARM))
    out = tmp_path / "out" / "copy.yaml"
    spec.dump(out)
    assert load_spec(out) == spec


def test_dump_writes_every_default(tmp_path):
    spec = load_spec(write(tmp_path, ARM))
    spec.dump(tmp_path / "copy.yaml")
    data = yaml.safe_load((tmp_path / "copy.yaml").read_text())
    q2 = data["joints"][1]
    assert q2["type"] == "P"
    assert q2["actuator"] == {"type": "torque", "limit": None}
    assert q2["friction"]["stribeck_velocity"] == 0.01
    assert data["joints"][0]["body"]["com"] == [0.5, 0.0, 0.0]
    assert "source" not in data


def test_dump_leaves_no_temporary_file(tmp_path):
    load_spec(write(tmp_path, ARM)).dump(tmp_path / "copy.yaml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm.yaml", "copy.yaml"]


@pytest.mark.parametrize("name", ["1e5", "1.5", "true", "null", "~", "-.inf", ".nan", "0x10", "1e-11"])
def test_dump_quotes_names_that_would_read_back_as_other_types(tmp_path, name):
    spec = load_spec(write(tmp_path, edited("name: arm", f"name: '{name}'")))
    assert spec.name == name
    spec.dump(tmp_path / "copy.yaml")
    assert load_spec(tmp_path / "copy.yaml").name == name


# --- fuzzing: garbage in, SpecError or a valid spec out ------------------------------------------

KEYS = ["name", "gravity", "joints", "end_effector", "type", "axis", "limits", "body", "actuator",
        "friction", "length", "direction", "mass", "com", "inertia", "model", "area", "volume",
        "valve_gain", "supply_pressure", "leakage", "coulomb", "offset", "size", "source"]  # fmt: skip
WORDS = ["R", "P", "Tr", "x", "y", "z", "torque", "hydraulic", "hybrid", "lugre", "none", "q1"]

scalars = (
    st.none()
    | st.booleans()
    | st.integers()
    | st.integers(min_value=-(10**400), max_value=10**400)
    | st.floats()
    | st.text(max_size=10)
    | st.sampled_from(WORDS)
)
junk = st.recursive(
    scalars,
    lambda inner: st.lists(inner, max_size=4)
    | st.dictionaries(st.sampled_from(KEYS) | st.text(max_size=4) | st.integers(), inner, max_size=4),
    max_leaves=10,
)
FUZZ = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def check_outcome(load) -> None:
    """``load()`` returns a spec that survives its own round trip, or raises SpecError."""
    try:
        spec = load()
    except ml.SpecError as error:
        assert str(error) and "\n" not in str(error)
        return
    assert isinstance(spec, ml.ManipulatorSpec)
    assert ml.ManipulatorSpec.from_dict(spec.to_dict()) == spec


@pytest.mark.filterwarnings("error")
@FUZZ
@given(data=junk)
def test_fuzz_random_data(data):
    check_outcome(lambda: ml.ManipulatorSpec.from_dict(data))


@pytest.mark.filterwarnings("error")
@FUZZ
@given(
    joints=st.lists(junk, min_size=1, max_size=3),
    top=st.dictionaries(st.sampled_from(KEYS), junk, max_size=3),
)
def test_fuzz_random_joints(joints, top):
    check_outcome(lambda: ml.ManipulatorSpec.from_dict({**top, "joints": joints}))


yaml_text = st.text(alphabet=" \n\t:-[]{},#'\"&*!|>%@`?.0129eqRzxynamejointsbody", max_size=80)


@pytest.mark.filterwarnings("error")
@FUZZ
@given(text=yaml_text | st.text(max_size=60) | junk.map(lambda d: yaml.safe_dump(d)))
def test_fuzz_random_yaml_text(tmp_path_factory, text):
    path = tmp_path_factory.getbasetemp() / "fuzz.yaml"
    path.write_text(text, encoding="utf-8")
    check_outcome(lambda: load_spec(path))


def paths_in(value, prefix=()):
    """Every path (tuple of keys and indices) inside nested dicts and lists."""
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else []
    for key, child in items:
        yield prefix + (key,)
        yield from paths_in(child, prefix + (key,))


@st.composite
def mutated(draw, original: dict) -> dict:
    """``original`` with 1-3 random keys deleted or values replaced by junk."""
    spec_dict = copy.deepcopy(original)
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(sorted(paths_in(spec_dict), key=str)))
        parent = spec_dict
        for key in path[:-1]:
            parent = parent[key]
        if draw(st.booleans()):
            del parent[path[-1]]
        else:
            parent[path[-1]] = draw(junk)
    return spec_dict


ERECTOR = ml.builtin_spec("erector").to_dict()
CRANE = ml.builtin_spec("crane3").to_dict()  # smaller: parsing YAML dominates the file test


@pytest.mark.filterwarnings("error")
@FUZZ
@given(spec_dict=mutated(ERECTOR))
def test_fuzz_mutations_of_a_valid_spec(spec_dict):
    check_outcome(lambda: ml.ManipulatorSpec.from_dict(spec_dict))


@pytest.mark.filterwarnings("error")
@settings(FUZZ, max_examples=100)
@given(spec_dict=mutated(CRANE))
def test_fuzz_mutations_of_a_valid_spec_file(tmp_path_factory, spec_dict):
    path = tmp_path_factory.getbasetemp() / "mutated.yaml"
    path.write_text(yaml.safe_dump(spec_dict), encoding="utf-8")
    check_outcome(lambda: load_spec(path))


def test_fuzz_helpers_reach_deep_fields():
    # the mutation test is only useful if it can hit fields deep inside a joint
    paths = set(paths_in(ml.builtin_spec("erector").to_dict()))
    assert ("joints", 0, "actuator", "leakage") in paths
    assert ("joints", 5, "body", "inertia", 5) in paths


def test_pathlike_and_str_paths_agree(tmp_path):
    path = write(tmp_path, ARM)
    assert load_spec(path) == load_spec(str(path)) == load_spec(os.fspath(path))
