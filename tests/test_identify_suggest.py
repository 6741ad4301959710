"""Experiment design (``suggest``) on crane3: the inputs it proposes are valid command-line inputs
within the valves' limits, they determine the parameters better than a poor experiment (whose
information this file computes on its own, by finite differences over ``ml.simulate``), and the
parameters the signals cannot determine are flagged."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import maniplab as ml
from maniplab.builtin import resolve_spec
from maniplab.errors import SpecError
from maniplab.identification.fit import IdentificationError
from maniplab.identification.suggest import Suggestion, suggest
from maniplab.sim.grammar import parse_input
from maniplab.sim.params import flatten_spec
from maniplab.spec import ManipulatorSpec

SPEC = "crane3"
POSE = {"slew": 0.0, "luff": -0.5, "telescope": 1.0}
"""The middle of crane3's joint ranges, where every candidate starts."""
NOISE = {"q": 1e-3, "qd": 1e-2, "dP": 1e5}
PAIR = ["end_effector.mass", "joints.telescope.friction.viscous"]


def fisher(inputs: list[tuple[str, ...]], paths: list[str], signals: tuple[str, ...],
           h: float = 0.01) -> np.ndarray:
    """The information of the parameters divided by their starts over experiments (each a tuple
    of --input texts), as a fit that also estimates each experiment's initial q and ΔP sees it:
    central differences of ±h, outputs divided by NOISE, every 10 ms; each experiment's
    information is what remains of SᵀS once the initial-state offsets are fitted too (the
    residual of S regressed on the offsets' sensitivities)."""
    spec = resolve_spec(SPEC)
    starts = {p: _value(spec, p) for p in paths}
    total = np.zeros((len(paths), len(paths)))
    for texts in inputs:
        drive: dict[str | int, object] = dict(parse_input(t) for t in texts)

        def outputs(overrides: dict[str, float], initial: dict[str, Any],
                    drive: dict[str | int, object] = drive) -> np.ndarray:
            run = ml.simulate(spec, inputs=drive, duration=5.0, overrides=overrides,
                              initial=initial, sample_dt=0.01, progress=False)
            return np.nan_to_num(np.concatenate([run[s].ravel() / NOISE[s] for s in signals]))

        nominal = ml.simulate(spec, inputs=drive, duration=5.0, sample_dt=0.01, progress=False,
                              initial={"q": POSE, "dP": "gravity"})
        pressures = np.array(nominal["dP"][0])
        start: dict[str, Any] = {"q": POSE, "dP": pressures} if "dP" in signals else \
            {"q": POSE, "dP": "gravity"}
        base = outputs({}, start)
        S = np.column_stack([(outputs({p: starts[p] * (1 + h)}, start)
                              - outputs({p: starts[p] * (1 - h)}, start)) / (2 * h)
                             for p in paths])
        offsets = []
        for k, joint in enumerate(spec.joint_names):
            offsets.append(outputs({}, {**start, "q": {**POSE, joint: POSE[joint] + NOISE["q"]}}))
            if "dP" in signals:
                moved = pressures.copy()
                moved[k] += NOISE["dP"]
                offsets.append(outputs({}, {**start, "dP": moved}))
        Z = np.column_stack(offsets) - base[:, None]
        S = S - Z @ np.linalg.lstsq(Z, S, rcond=None)[0]
        total += S.T @ S
    return total


def _value(spec: ManipulatorSpec, path: str) -> float:
    return float(flatten_spec(spec)[path])


def relative_std(F: np.ndarray) -> np.ndarray:
    """sqrt(diag(F⁻¹)), inf for a parameter without information (the others as if it were
    fixed: optimistic for them)."""
    seen = np.diag(F) > 0
    std = np.full(len(F), np.inf)
    std[seen] = np.sqrt(np.diag(np.linalg.inv(F[np.ix_(seen, seen)])))
    return std


def correlation(F: np.ndarray) -> np.ndarray:
    cov = np.linalg.inv(F)
    d = np.sqrt(np.diag(cov))
    return cov / np.outer(d, d)


@pytest.fixture(scope="module")
def design() -> Suggestion:
    """The payload and the telescope's viscous friction from q and dP, every joint excitable."""
    return suggest(SPEC, PAIR, workers=2, progress=False)


def test_the_suggested_inputs_are_valid_command_line_inputs_within_the_limits(
        design: Suggestion) -> None:
    spec = resolve_spec(SPEC)
    assert 1 <= len(design.experiments) <= 3
    assert len(set(design.experiments)) == len(design.experiments)
    assert design.duration == 5.0 and design.initial == POSE
    t = np.arange(0.0, 5.0, 1e-3)
    report = design.report()
    for texts in design.experiments:
        assert texts, "an experiment without inputs"
        for text in texts:
            joint, signal = parse_input(text)
            assert joint in spec.joint_names
            u = signal.sample(t)
            limit = spec.joint(joint).actuator.current_limit
            assert 0.1 * limit <= np.abs(u).max() <= limit + 1e-12, text
            assert f"--input {text}" in report
    for path in PAIR:
        assert path in report
    assert "|---|" in report


def test_the_suggestion_determines_the_parameters_better_than_a_poor_experiment(
        design: Suggestion) -> None:
    """A single tiny step of the slew (the boom and the telescope stay still; the payload's
    inertia still shows in the slew) against the suggested set: each parameter's predicted
    relative std is at least 3x smaller (measured: 4.7x for the payload, 5e4x for the friction)."""
    poor = relative_std(fisher([("slew=step:0.05@0.5",)], PAIR, ("q", "dP")))
    assert np.all(np.isfinite(design.relative_std))
    assert np.all(design.relative_std * 3 <= poor), (design.relative_std, poor)
    assert not design.warnings, design.warnings


def test_the_predicted_precision_agrees_with_an_independent_estimate(design: Suggestion) -> None:
    """The payload's dependence is smooth: the suggestion's prediction and central differences
    of its own agree within 20 %; the friction's is rough (stick/slip), where the suggestion's
    gentlest secants may only be more cautious, not more optimistic, by more than 2x."""
    own = relative_std(fisher(list(design.experiments), PAIR, ("q", "dP")))
    mass, viscous = design.relative_std
    assert own[0] == pytest.approx(mass, rel=0.2)
    assert viscous >= own[1] / 2.0, (viscous, own[1])


def test_a_parameter_the_signals_do_not_depend_on_is_flagged() -> None:
    """Only the telescope may move: the slew's cylinder then holds no pressure (its axis is
    vertical, the telescope pushes radially), so its leakage changes nothing."""
    leak = suggest(SPEC, ["joints.slew.actuator.leakage"], joints=["telescope"], workers=2,
                   progress=False)
    assert all(texts[0].startswith("telescope=") for texts in leak.experiments)
    assert leak.relative_std[0] == np.inf
    assert any("joints.slew.actuator.leakage has no effect" in w for w in leak.warnings)
    # the premise, checked directly: ten times the leakage, the very same run
    drive: dict[str | int, object] = dict([parse_input(leak.experiments[0][0])])
    runs = [ml.simulate(SPEC, inputs=drive, duration=5.0, initial={"q": POSE, "dP": "gravity"},
                        overrides={"joints.slew.actuator.leakage": value}, sample_dt=0.01,
                        progress=False) for value in (1e-12, 1e-11)]
    assert np.abs(runs[0]["q"][:, 2] - runs[0]["q"][0, 2]).max() > 1e-3  # the telescope moves
    for signal in ("q", "dP"):
        np.testing.assert_array_equal(runs[0][signal], runs[1][signal])


def test_friction_seen_in_positions_alone_is_flagged_as_poorly_identifiable(
        design: Suggestion) -> None:
    """The telescope's valve sets its speed whatever the friction: from q alone its viscous
    friction is poorly determined (flagged), from q and its pressure it is not."""
    alone = suggest(SPEC, ["joints.telescope.friction.viscous"], signals=("q",),
                    joints=["telescope"], workers=2, progress=False)
    assert alone.relative_std[0] > 0.5
    assert any("joints.telescope.friction.viscous stays poorly identifiable" in w
               for w in alone.warnings)
    assert design.relative_std[1] < 0.5


def test_two_masses_the_boom_carries_alike_are_flagged_as_correlated() -> None:
    """Moving only the boom, from positions alone, the payload and the telescope's own mass
    load it almost alike."""
    paths = ["end_effector.mass", "joints.telescope.body.mass"]
    masses = suggest(SPEC, paths, signals=("q",), joints=["luff"], workers=2, progress=False)
    assert masses.worst_correlation is not None
    a, b, c = masses.worst_correlation
    assert {a, b} == set(paths) and abs(c) > 0.95
    assert any("stay correlated" in w for w in masses.warnings)
    own = correlation(fisher(list(masses.experiments), paths, ("q",)))
    assert abs(own[0, 1]) > 0.95


@pytest.mark.parametrize("kwargs, error, words", [
    ({"params": ["joints.nope.friction.coulomb"]}, SpecError, "joints.nope.friction.coulomb"),
    ({"signals": ("q", "force")}, IdentificationError, "force"),
    ({"joints": ["boom"]}, IdentificationError, "boom"),
    ({"duration": 0.5}, IdentificationError, "duration"),
    ({"noise": {"q": -1.0}}, IdentificationError, "noise of q"),
])
def test_bad_arguments_raise_one_line(kwargs: dict[str, object], error: type[Exception],
                                      words: str) -> None:
    args: dict[str, object] = {"params": ["end_effector.mass"], **kwargs}
    with pytest.raises(error) as info:
        suggest(SPEC, **args)  # type: ignore[arg-type]
    assert words in str(info.value) and "\n" not in str(info.value)
