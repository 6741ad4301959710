"""A valve's command as its datasheet gives it (issue 34, part): a deadband around neutral, or an
opening characteristic of (command, opening) points, in the plant (the spool settles where the
closed forms written here put it), in the controller (it inverts them) and in bad specs."""

from __future__ import annotations

import numpy as np
import pytest

import maniplab as ml
from maniplab.errors import SpecError

VALVE = "joints.lift.actuator.valve"
TABLE = [[-1.0, -1.0], [-0.15, 0.0], [0.15, 0.0], [0.5, 0.3], [1.0, 1.0]]
"""A progressive characteristic with a ±0.15 overlap (command from neutral, opening)."""


def settled_spool(spec: ml.ManipulatorSpec, command: float) -> float:
    """The lift spool's opening after 12 time constants at a constant command."""
    tau = spec.joint("lift").actuator.valve.tau
    run = ml.simulate(spec, inputs={"lift": command}, duration=12 * tau,
                      initial={"dP": "gravity"}, sample_dt=12 * tau)
    return float(run["spool"][-1, 1])


@pytest.mark.parametrize("command", [-1.0, -0.6, -0.2, 0.1, 0.25, 0.6, 1.0])
def test_a_deadband_shuts_the_spool_around_neutral_and_opens_it_linearly_beyond(command):
    """deadband 0.2 of a 1.0 command range: opening (|u| - 0.2)/0.8 with u's sign beyond it."""
    spec = ml.builtin_spec("patu655").with_overrides({f"{VALVE}.deadband": 0.2})
    expected = 0.0 if abs(command) <= 0.2 else np.sign(command) * (abs(command) - 0.2) / 0.8
    assert settled_spool(spec, command) == pytest.approx(expected, abs=1e-5)


@pytest.mark.parametrize("point", TABLE + [[0.75, 0.65], [-0.5, -7.0 / 17.0]])
def test_a_characteristic_reproduces_its_points_and_interpolates_between(point):
    """At each point's command the spool settles at its opening; between two points on the
    straight line joining them (the last two cases: 0.75 halfway from 0.5 to 1.0, and -0.5 from
    -1.0 to -0.15)."""
    spec = ml.builtin_spec("patu655").with_overrides({f"{VALVE}.characteristic": TABLE})
    command, opening = point
    assert settled_spool(spec, command) == pytest.approx(opening, abs=1e-5)


@pytest.mark.parametrize("valve", [{"deadband": 0.25}, {"characteristic": TABLE}])
def test_the_cascade_inverts_the_command_characteristic(valve):
    """The drive asks the opening it needs of the command that gives it (past the deadband,
    along the characteristic): a move of patu655 ends within 5 mm of its target."""
    from maniplab.control.move import run_move

    changes = {f"joints.{j}.actuator.valve.{k}": v for j in ("lift", "tilt")
               for k, v in valve.items()}
    spec = ml.builtin_spec("patu655").with_overrides(changes)
    model = ml.AnalyticModel(spec)
    target = model.fk(np.array([0.3, -0.45, 1.0]))[:3, 3]
    result = run_move(spec, target, start=[0.0, -0.3, 1.2], duration=4.0, settle=1.0,
                      sample_dt=5e-3)
    assert np.linalg.norm(model.fk(result.run.q[-1])[:3, 3] - target) < 5e-3


@pytest.mark.parametrize("changes, field, words", [
    ({"deadband": 1.0}, "actuator.valve", ["deadband 1 is not below current_limit 1"]),
    ({"deadband": 0.1, "characteristic": TABLE}, "actuator.valve", ["not both"]),
    ({"characteristic": [[-1.0, -1.0], [0.0, 0.2], [1.0, 1.0]]}, "actuator.valve",
     ["shut (opening 0) at the neutral command"]),
    ({"characteristic": [[-1.0, 0.5], [0.0, 0.0], [1.0, 1.0]]}, "actuator.valve",
     ["openings must not fall"]),
    ({"characteristic": [[-2.0, -1.0], [0.0, 0.0], [1.0, 1.0]]}, "actuator.valve",
     ["within ±current_limit"]),
    ({"characteristic": [[k / 10.0, 0.0] for k in range(-8, 9)]}, "actuator.valve",
     ["17 points; expected 2 to 16"]),
    ({"command_unit": "volt"}, "actuator.valve.command_unit", ["'A', 'mA', 'V' or '%'"]),
])
def test_a_bad_command_description_is_one_line(changes, field, words):
    with pytest.raises(SpecError) as caught:
        ml.builtin_spec("patu655").with_overrides(
            {f"{VALVE}.{k}": v for k, v in changes.items()})
    error = caught.value
    assert "\n" not in str(error) and error.joint == "lift" and error.field == field
    for word in words:
        assert word in str(error), (word, str(error))
