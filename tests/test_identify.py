"""System identification on data made by the plant with known true parameters plus noise (σ in
``identify_data.NOISE``): the true values are recovered and lie in the confidence intervals;
parameters the data cannot separate are flagged; bad files and parameters get one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from commandline import run_cli
from identify_data import synthetic

import maniplab as ml
from maniplab.errors import SpecError
from maniplab.identification import (
    DataError,
    Experiment,
    IdentificationError,
    identify,
    load_experiments,
    save_csv,
)
from maniplab.identification.parameters import parse_parameters

S = ml.signals
CRANE_INPUTS = {"slew": S.sine(0.4, 0.5, t0=0.3), "luff": S.sine(0.3, 0.3, t0=0.3),
                "telescope": S.step(0.5, 0.3) + S.step(-1.0, 1.8) + S.step(0.8, 3.3)}
CRANE_START = [0.0, -0.3, 0.5]

SLEW_FRICTION = {"slew": S.step(0.01, 0.2) + S.step(0.99, 2.0) + S.step(-1.6, 3.0)}
"""A friction experiment: a creep that builds the pressure slowly until the joint breaks away
(static), then two speeds, one each way (Coulomb against viscous)."""


def assert_recovered(result, truth: dict[str, float], rel: dict[str, float] | None = None) -> None:
    """Within 5 % of the truth (or ``rel[path]``), and the truth inside the 95 % interval."""
    for p, value, (lo, hi) in zip(result.parameters, result.values, result.interval):
        assert value == pytest.approx(truth[p.path], rel=(rel or {}).get(p.path, 0.05)), p.path
        assert lo <= truth[p.path] <= hi, (p.path, lo, hi)


def test_payload_leakage_and_bulk_modulus_are_recovered_on_crane3() -> None:
    spec = ml.builtin_spec("crane3")
    truth = {"joints.luff.actuator.leakage": 3e-12, "joints.slew.actuator.bulk_modulus": 0.8e9,
             "end_effector.mass": 130.0}
    data = synthetic(spec, truth, CRANE_INPUTS, CRANE_START, 4.0)
    result = identify(spec, [data], list(truth), progress=False)
    assert_recovered(result, truth)
    assert result.residual_rms["q"] < 1.5e-4 and result.residual_rms["dP"] < 3e4  # ~ the noise
    # crane3's slew sticks and slips in this experiment: at its derived step (0.5 ms) the cost
    # steps by ~20 s² where a joint sticks a plant step earlier, and the intervals are widened
    # over those steps (×2.6 to ×3.8, said in the one warning); nothing else may warn
    assert all("the cost steps where joints stick" in w for w in result.warnings)
    assert result.spec.end_effector.mass == pytest.approx(result.values[2])


def test_friction_is_recovered_on_crane3() -> None:
    spec = ml.builtin_spec("crane3")
    truth = {"joints.slew.friction.coulomb": 165.0, "joints.slew.friction.static": 54.0,
             "joints.slew.friction.viscous": 220.0}
    data = synthetic(spec, truth, SLEW_FRICTION, CRANE_START, 4.5)
    result = identify(spec, [data], list(truth), progress=False)
    # stiction and viscous friction show only at the few break-aways and slow stretches: at the
    # derived step (0.5 ms) the fit lands 5 to 6 % off on one of them (static 5.9 %, viscous
    # 5.0 % measured), its 95 % interval holding the truth
    assert_recovered(result, truth, rel={"joints.slew.friction.static": 0.08,
                                         "joints.slew.friction.viscous": 0.08})
    assert result.residual_rms["dP"] < 2.5e4  # the noise, 2e4: the fit found the valley


ERECTOR_WRIST = {"q6": S.step(0.01, 0.2) + S.step(0.29, 1.2) + S.step(-0.6, 2.0) + S.step(0.3, 3.2)}
"""The same kind of experiment on the erector's wrist roll, moved alone; its oil column is soft
under the payload's inertia, so small currents keep it within its ±0.3 rad."""


def test_friction_is_recovered_on_the_erector() -> None:
    spec = ml.builtin_spec("erector")
    truth = {"joints.q6.friction.coulomb": 165.0, "joints.q6.friction.static": 72.0,
             "joints.q6.friction.viscous": 220.0}
    data = synthetic(spec, truth, ERECTOR_WRIST, [0.0] * 6, 4.0)
    result = identify(spec, [data], list(truth), progress=False)
    assert_recovered(result, truth)


def test_leakage_bulk_modulus_and_payload_are_recovered_on_the_erector() -> None:
    spec = ml.builtin_spec("erector")
    truth = {"joints.q6.actuator.leakage": 3e-12, "joints.q6.actuator.bulk_modulus": 0.8e9,
             "end_effector.mass": 4400.0}
    wrist = {"q6": S.step(0.02, 0.2) + S.step(0.5, 1.5) + S.step(-1.0, 3.0)}  # to its stop
    data = synthetic(spec, truth, wrist, [0.0] * 6, 4.5)
    result = identify(spec, [data], list(truth), progress=False)
    assert_recovered(result, truth)



def test_a_pinned_cylinders_valve_is_recovered_from_pressures_five_times_off() -> None:
    """patu655's lift valve: its nominal flow and its B/A flow ratio, fitted from the lift's
    position and chamber pressures (noise 0.1 mm, 0.2 bar), from a start five times off each
    way."""
    spec = ml.builtin_spec("patu655")
    flow, ratio = "joints.lift.actuator.valve.nominal_flow", "joints.lift.actuator.valve.flow_ratio"
    truth = {flow: 6.0e-4, ratio: 0.6}
    lift = {"lift": S.step(0.4, 0.1) + S.step(-0.8, 0.6) + S.step(0.4, 1.1)}
    data = synthetic(spec, truth, lift, [0.0, -0.3, 1.2], 1.5, rate=0.004,
                     noise={"q": 1e-4, "pA": 2e4, "pB": 2e4})
    start = spec.with_overrides({flow: 5.0 * truth[flow], ratio: truth[ratio] / 5.0})
    assert_recovered(identify(start, [data], list(truth), progress=False), truth)

def test_an_experiment_whose_simulation_is_chaotic_is_refused() -> None:
    """Moving the erector's boom drags its shoulder and wrist into stick/slip chatter whose phase
    a millionth of a pascal changes: one line names the joint, and no fit is made."""
    spec = ml.builtin_spec("erector")
    data = synthetic(spec, {}, {"q2": S.step(0.3, 0.2) + S.step(-0.6, 2.0)}, [0.0] * 6, 3.0)
    with pytest.raises(IdentificationError, match=r"joint q\d's dP is chaotic") as info:
        identify(spec, [data], ["joints.q2.friction.coulomb"], progress=False)
    assert "\n" not in str(info.value)


def test_two_parameters_the_data_cannot_separate_are_flagged() -> None:
    """With positions alone, a valve's gain and its cylinder's area act mostly as their ratio."""
    spec = ml.builtin_spec("crane3")
    truth = {"joints.luff.actuator.valve_gain": 0.0011, "joints.luff.actuator.area": 0.0026}
    data = synthetic(spec, truth, {"luff": S.sine(0.3, 0.3, t0=0.3)}, CRANE_START, 3.0)
    positions = Experiment(data.name, data.t, data.inputs,
                           {k: v for k, v in data.measured.items() if k[0] == "q"})
    result = identify(spec, [positions], list(truth), progress=False)
    assert abs(result.correlation[0, 1]) > 0.95
    assert any("cannot be told apart" in w and "valve_gain" in w and "area" in w
               for w in result.warnings)


def test_the_command_line_goes_from_csv_to_a_fitted_spec(tmp_path: Path, capsys) -> None:
    spec = ml.builtin_spec("crane3")
    true = spec.with_overrides({"end_effector.mass": 150.0})
    t = np.arange(0.0, 2.0 + 1e-9, 0.002)
    inputs = {j: S.held(t, s.sample(t)) for j, s in CRANE_INPUTS.items()}
    run = ml.simulate(true, inputs=inputs, duration=2.0, sample_dt=0.002,
                      initial={"q": CRANE_START, "dP": "gravity"})
    csv = save_csv(run, tmp_path / "rig.csv")
    fitted, figure = tmp_path / "fitted.yaml", tmp_path / "fit.png"
    code, out, err = run_cli(capsys, "identify", "crane3", str(csv), "--params",
                             "end_effector.mass[0:1000]", "-o", str(fitted), "--figure", str(figure))
    assert code == 0, err
    assert ml.load_spec(fitted).end_effector.mass == pytest.approx(150.0, rel=1e-3)
    assert figure.stat().st_size > 10_000 and "end_effector.mass" in out


def test_held_inputs_keep_each_sample_until_the_next() -> None:
    u = S.held(np.array([0.0, 0.1, 0.3]), np.array([1.0, 2.0, 3.0]))
    np.testing.assert_array_equal(u.sample(np.array([-1.0, 0.0, 0.05, 0.1, 0.2999, 0.3, 9.0])),
                                  [1.0, 1.0, 1.0, 2.0, 2.0, 3.0, 3.0])


# --- bad input -----------------------------------------------------------------------------------

@pytest.mark.parametrize(("text", "words"), [
    ("ctrl.luff,q.luff\n0,0\n1,0\n", "no column 't'"),
    ("t,q.luf\n0,0\n1,0\n", "no joint 'luf'"),
    ("t,position.luff\n0,0\n1,0\n", "column 'position.luff'"),
    ("t,q.luff\n0,0\n1,nan\n", "line 3, column 'q.luff'"),
    ("t,q.luff\n0,0\n1,abc\n", "'abc' is not a number"),
    ("t,q.luff\n0,0\n0,1\n", "line 3: time 0 s is not after"),
    ("t,ctrl.luff\n0,0\n1,0\n", "no measured position"),
    ("t,q.luff\n0,0,1\n1,0\n", "line 2: 3 values for 2 columns"),
])
def test_a_bad_csv_is_one_line_naming_the_file_and_column(tmp_path: Path, text: str,
                                                          words: str, capsys) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(DataError, match="bad.csv") as info:
        load_experiments([path], ml.builtin_spec("crane3"))
    assert words in str(info.value) and "\n" not in str(info.value)
    code, _, err = run_cli(capsys, "identify", "crane3", str(path), "--params",
                           "end_effector.mass")
    assert code == 2 and words in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(("text", "words"), [
    ("joints.luff.friction.colomb", "no value at 'joints.luff.friction.colomb'"),
    ("joints.luff.actuator.leakage[1:2]", "outside [1, 2]"),
    ("end_effector.mass[a:2]", "bound 'a' is not a number"),
    ("end_effector.offset", "is not a number"),
])
def test_a_bad_parameter_is_one_line(text: str, words: str) -> None:
    with pytest.raises(SpecError, match="parameter") as info:
        parse_parameters([text], ml.builtin_spec("crane3"))
    assert words in str(info.value)


def test_a_parameter_starting_at_zero_asks_for_a_start() -> None:
    spec = ml.builtin_spec("crane3").with_overrides({"joints.slew.friction.viscous": 0.0})
    with pytest.raises(SpecError, match="give a first guess with --set"):
        parse_parameters(["joints.slew.friction.viscous"], spec)


def test_suggest_from_the_command_line_needs_no_data_and_a_fit_needs_data(capsys) -> None:
    code, _, err = run_cli(capsys, "identify", "crane3", "--params", "end_effector.mass")
    assert code == 2 and "no data" in err
    code, out, _ = run_cli(capsys, "identify", "crane3", "--suggest", "--duration", "2",
                           "--params", "end_effector.mass")
    assert code == 0 and "--input " in out and "predicted" in out


def test_scale_parameters_are_reached_from_ten_times_off_either_way() -> None:
    """Positive parameters are searched on the log scale (log of the value over its start): the
    luff's leakage from ten times too large and the payload from ten times too small, fitted from
    1.5 s of the luff's steps (measured: both within 0.04 %, in 800 simulations; the linear scale,
    value over start, reaches them too, in 780, and so do both from a leakage 100 times off)."""
    import math

    spec = ml.builtin_spec("crane3")
    leakage = "joints.luff.actuator.leakage"
    truth = {leakage: 3e-12, "end_effector.mass": 130.0}
    luff = {"luff": S.step(-0.3, 0.1) + S.step(0.6, 0.6) + S.step(-0.3, 1.1)}
    data = synthetic(spec, truth, luff, CRANE_START, 1.5, rate=0.004)
    start = spec.with_overrides({leakage: 10.0 * truth[leakage], "end_effector.mass": 13.0})
    parameters = parse_parameters(list(truth), start)
    assert all(p.log_scale for p in parameters)
    result = identify(start, [data], parameters, progress=False)
    assert_recovered(result, truth)
    # the interval is the exponential of the log's: value exp(±1.96 std/value)
    for (lo, hi), value, std in zip(result.interval, result.values, result.std):
        assert hi / value == pytest.approx(value / lo, rel=1e-12)
        assert math.log(hi / value) == pytest.approx(1.96 * std / value, rel=1e-9)


def test_parameters_that_may_be_negative_keep_the_linear_scale() -> None:
    import math

    from maniplab.identification.parameters import Parameter

    spec = ml.builtin_spec("crane3")
    positive, bounded, signed = parse_parameters(
        ["end_effector.mass", "joints.luff.actuator.leakage[1e-13:1e-11]",
         "joints.slew.friction.viscous[-50:500]"], spec)
    assert positive.log_scale and bounded.log_scale and not signed.log_scale
    assert not Parameter("joints.luff.body.mass", -2.0, -math.inf, 0.0).log_scale


def test_a_valve_is_recovered_from_cylinder_strokes_and_pressures_alone() -> None:
    """A rig with length transducers in its cylinders and no joint encoders: patu655's lift
    valve's nominal flow from the lift's stroke (noise 0.1 mm) and chamber pressures (0.2 bar),
    from a start five times too large; the arm's start comes from the measured strokes (the
    pins' geometry inverted). The fit runs at the data's step (`dt`, the true arm's 1 ms): at
    the start's derived 0.5 ms the data's discretization alone moves it by 1 %, beyond an
    interval of ±0.3 % that counts the noise only."""
    spec = ml.builtin_spec("patu655")
    flow = "joints.lift.actuator.valve.nominal_flow"
    truth = {flow: 6.0e-4}
    start = spec.with_overrides({flow: 5.0 * truth[flow]})
    lift = {"lift": S.step(0.4, 0.1) + S.step(-0.8, 0.5)}
    data = synthetic(spec, truth, lift, [0.0, -0.3, 1.2], 0.9, rate=0.004,
                     noise={"stroke": 1e-4, "pA": 2e4, "pB": 2e4})
    assert {signal for signal, _ in data.measured} == {"stroke", "pA", "pB"}
    step = ml.Plant(spec.with_overrides(truth)).dt
    assert step > ml.Plant(start).dt
    assert_recovered(identify(start, [data], list(truth), progress=False, dt=step), truth)
