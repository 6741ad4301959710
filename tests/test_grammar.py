"""The command line's input grammar: each form gives the signal it names; malformed text is a
one-line GrammarError."""

from __future__ import annotations

import numpy as np
import pytest

from maniplab.sim.grammar import GrammarError, parse_assignment, parse_input, parse_variation


@pytest.mark.parametrize(
    ("text", "times", "values"),
    [
        ("q2=step:1.5@0.2", [0.0, 0.19, 0.2, 3.0], [0.0, 0.0, 1.5, 1.5]),
        ("q1=0.25", [0.0, 7.0], [0.25, 0.25]),
        ("q1=constant:-2", [1.0], [-2.0]),
        ("q1=sine:2,0.5", [0.0, 0.5, 1.5], [0.0, 2.0, -2.0]),  # sin(2π·0.5·t)
        ("q1=sine:1,1,1.5707963267948966", [0.0], [1.0]),
        ("q1=ramp:2@1", [0.5, 1.0, 2.5], [0.0, 0.0, 3.0]),
        ("q1=ramp:2,1.5@1", [2.5], [1.0]),
        ("q1=impulse:0.01,0.01@1", [0.995, 1.005, 1.02], [0.0, 1.0, 0.0]),
        ("q3=step:1e+3@1e-1+2", [0.0, 0.2], [2.0, 1002.0]),
        ("q1=step:1@1 + step:-1@2", [0.5, 1.5, 2.5], [0.0, 1.0, 0.0]),
    ],
)
def test_forms_give_the_named_signal(text: str, times: list[float], values: list[float]) -> None:
    joint, signal = parse_input(text)
    assert joint == text.split("=")[0]
    assert np.allclose([signal(t) for t in times], values, atol=1e-12)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("q2", "expected JOINT=SIGNAL"),
        ("=step:1", "expected JOINT=SIGNAL"),
        ("q2=stp:1", "unknown signal 'stp'; expected step"),
        ("q2=step:abc", "'abc' is not a number"),
        ("q2=step:1@soon", "'soon' is not a number"),
        ("q2=sine:1", "expected sine:amplitude,frequency[,phase], got 1 values"),
        ("q2=step:1,2", "expected step:amplitude, got 2 values"),
        ("q2=constant:1@2", "constant takes no @T0"),
        ("q2=1,2", "is not a number; name the signal"),
    ],
)
def test_malformed_inputs_say_what_is_expected(text: str, words: str) -> None:
    with pytest.raises(GrammarError) as info:
        parse_input(text)
    message = str(info.value)
    assert words in message and text in message and "\n" not in message


def test_assignments_and_variations_read_yaml_values() -> None:
    assert parse_assignment("end_effector.mass=4000") == ("end_effector.mass", 4000)
    assert parse_assignment("joints.q2.actuator.leakage=1e-11") == ("joints.q2.actuator.leakage", 1e-11)
    assert parse_variation("end_effector.mass=3000,4000") == ("end_effector.mass", [3000, 4000])
    assert parse_variation("gravity=[0,0,-9.81],[0,-9.81,0]") == (
        "gravity", [[0, 0, -9.81], [0, -9.81, 0]])
    for bad in ("mass", "=3", "x="):
        with pytest.raises(GrammarError, match="expected PATH=VALUE"):
            parse_assignment(bad)
    with pytest.raises(GrammarError, match="expected PATH=V1,V2"):
        parse_variation("end_effector.mass")
