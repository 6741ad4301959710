"""The spec file's optional ``control:`` section: defaults, validation, messages, overrides."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import maniplab as ml
from maniplab.spec import CartesianGains, ControlSpec, PressureGains

ARM = """name: arm
joints:
  - {type: R, axis: z, body: {length: 1.0, mass: 2.0}}
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "arm.yaml"
    path.write_text(text)
    return path


def test_absent_section_is_none_and_not_written(tmp_path: Path) -> None:
    spec = ml.load_spec(write(tmp_path, ARM))
    assert spec.control is None
    assert "control" not in spec.to_dict()


def test_section_with_defaults_round_trips(tmp_path: Path) -> None:
    spec = ml.load_spec(write(tmp_path, ARM + """control:
  rate: 250
  task: position
  position: {kp: 100, kd: 20}
  pressure: {bandwidth: 30.0, speed_gain: 0.5}
"""))
    c = spec.control
    assert c.rate == 250.0 and c.task == "position"
    assert c.position == CartesianGains(kp=100.0, ki=None, kd=20.0)  # ki: derived from the arm
    assert c.orientation == ControlSpec().orientation
    assert c.pressure == PressureGains(bandwidth=30.0, speed_gain=0.5)
    out = tmp_path / "out.yaml"
    spec.dump(str(out))
    assert ml.load_spec(out) == spec


@pytest.mark.parametrize(("text", "field", "words"), [
    ("control: {rate: -5}", "control.rate", "expected a number > 0"),
    ("control: {task: joint}", "control.task", "expected 'position' or 'pose'"),
    ("control: {pressure: {bandwith: 3}}", "control.pressure.bandwith", "did you mean 'bandwidth'"),
    ("control: {position: {kd: -3}}", "control.position.kd", "expected a number >= 0"),
    ("control: {position: 3}", "control.position", "expected a mapping"),
    ("control: {valve_min_root: 2}", "control.valve_min_root", "<= 1"),
    ("control: {coulomb_feedforward: maybe}", "control.coulomb_feedforward", "true or false"),
    ("control: {rat: 5}", "control.rat", "did you mean 'rate'"),
    ("control: {pid_only: {kp: [1.0, -2.0]}}", "control.pid_only.kp",
     "expected a number >= 0 or a list of one per joint"),
    ("control: {pid_only: {ki: [1.0, 2.0]}}", "control", "pid_only.ki has 2 gains for 1 joints"),
])
def test_bad_control_section_names_file_and_field(tmp_path: Path, text: str, field: str,
                                                  words: str) -> None:
    path = write(tmp_path, ARM + text + "\n")
    with pytest.raises(ml.SpecError) as info:
        ml.load_spec(path)
    message = str(info.value)
    assert str(path) in message and f"field '{field}'" in message, message
    assert words in message, message
    assert info.value.line == 4


def test_overrides_reach_the_control_section() -> None:
    spec = ml.builtin_spec("erector")
    tuned = spec.with_overrides({"control.rate": 250.0, "control.pressure.bandwidth": 20.0})
    assert tuned.control.rate == 250.0 and tuned.control.pressure.bandwidth == 20.0
    assert tuned.control.position == ControlSpec().position
    with pytest.raises(ml.SpecError, match="did you mean 'pressure'"):
        spec.with_overrides({"control.pressur.bandwidth": 1.0})


def test_per_joint_baseline_gains_round_trip_and_reach_the_controller(tmp_path: Path) -> None:
    spec = ml.builtin_spec("crane3").with_overrides({"control.pid_only.kp": [0.5, 1.0, 2.0],
                                                    "control.pid_only.ki": 0.25})
    out = tmp_path / "crane3.yaml"
    spec.dump(out)
    assert ml.load_spec(out) == spec and spec.control.pid_only.kp == (0.5, 1.0, 2.0)
    move = ml.MinJerkMove(ml.Pose([5.0, 0.0, 1.0], np.eye(3)), ml.Pose([5.0, 0.5, 1.0], np.eye(3)),
                          1.0)
    pid = ml.CascadeController(spec, move, mode="pid").joint_pid
    np.testing.assert_array_equal(pid.kp, [0.5, 1.0, 2.0])
    np.testing.assert_array_equal(pid.ki, [0.25, 0.25, 0.25])


def test_constructed_in_python_is_validated() -> None:
    with pytest.raises(ml.SpecError, match="field 'rate': expected a number > 0, got 0.0"):
        ControlSpec(rate=0.0)
    with pytest.raises(ml.SpecError, match="field 'kp': expected a number >= 0, got -1.0"):
        CartesianGains(kp=-1.0)
