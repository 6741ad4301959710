"""Fuzzing the plant's C API (plant.c) under ASan and UBSan through maniplab's Plant.

Hostile values (NaN, ±inf, ±0, subnormals, 1e±308, huge and negative numbers) go to: Plant
construction (dt, integrator), set_state (q, qd, the actuators' named states), prepare/advance
and step with hostile commands (and advance without prepare), save/restore of hostile state
vectors, balance_pressures, and whole runs of ``ml.simulate`` (durations, sample intervals,
constant inputs, a Python controller with a hostile period and hostile commands). Every call
must either work or raise one of maniplab's errors; a memory error or undefined behaviour in C
aborts the process with the sanitizer's report.

Run as a script (``python tests/sanitize/fuzz_plant.py``; it re-runs itself sanitized) or with
pytest in a sanitized process (``python tests/sanitize/run.py``).
"""

from __future__ import annotations

import math
import sys
from functools import cache
from typing import Any

import numpy as np
import pytest
from hypothesis import event, given
from hypothesis import strategies as st
from sanitized import ARMS, fuzz_settings, reexec_sanitized, report_of, run_child, spec_of

HOSTILE = [math.nan, math.inf, -math.inf, 0.0, -0.0, 5e-324, -5e-324, 1e-308, 1e-300, 1e308,
           -1e308, 1e300, 1e18, -1e18, 1e10, -1e10, 1e3, -1e3, 1.0, -1.0]
"""Values every numeric input is tried with."""

EXAMPLES = 60


def hostile() -> st.SearchStrategy[float]:
    """A number: one of :data:`HOSTILE`, an ordinary one, or any double."""
    return st.one_of(st.sampled_from(HOSTILE), st.floats(-100.0, 100.0),
                     st.floats(allow_nan=True, allow_infinity=True))


def ordinary() -> st.SearchStrategy[float]:
    """A finite command or state of a plausible size (valve currents, forces, positions)."""
    return st.one_of(st.floats(-1.0, 1.0), st.floats(-1e4, 1e4))


def vectors(n: int) -> st.SearchStrategy[list[float]]:
    """n values: mostly finite, a third with hostile entries."""
    return st.one_of(st.lists(ordinary(), min_size=n, max_size=n),
                     st.lists(ordinary(), min_size=n, max_size=n),
                     st.lists(hostile(), min_size=n, max_size=n))


def errors() -> tuple[type[BaseException], ...]:
    """What a refused call may raise: maniplab's errors."""
    import maniplab as ml

    return (ml.ManiplabError,)


@cache
def plant(arm: str) -> Any:
    """One plant per arm at its default step (reset before each example)."""
    import maniplab as ml

    return ml.Plant(spec_of(arm))


arms = st.sampled_from(sorted(ARMS))


# --- construction ---------------------------------------------------------------------------
@fuzz_settings(EXAMPLES)
@given(arm=arms, dt=st.one_of(hostile(), st.floats(1e-6, 0.05)),
       integrator=st.sampled_from(["RK4", "Euler", "implicit", "implicitfast", "rk4", "", "x"]),
       u=st.one_of(st.lists(ordinary(), min_size=1, max_size=1),
                   st.lists(hostile(), min_size=0, max_size=8)))
def test_construction(arm: str, dt: float, integrator: str, u: list[float]) -> None:
    """Plant(spec, dt, integrator), then a step with a command vector of any length."""
    import maniplab as ml

    try:
        p = ml.Plant(spec_of(arm), dt=dt, integrator=integrator)
    except errors() as exc:
        event(f"plant refused: {type(exc).__name__}")
        return
    if len(u) == 1:
        u = u * p.n
    try:
        p.step(u)
        event("stepped")
    except errors() as exc:
        event(f"step refused: {type(exc).__name__}")
    assert p.n == len(p.record.q)


# --- the stepping calls ----------------------------------------------------------------------
def operations(n: int, states: list[str]) -> st.SearchStrategy[list[tuple[Any, ...]]]:
    state = st.one_of(
        st.tuples(st.just("q"), vectors(n)), st.tuples(st.just("qd"), vectors(n)),
        st.tuples(st.just("t"), hostile()),
        *[st.tuples(st.just(name), vectors(n)) for name in states])
    op = st.one_of(
        st.tuples(st.just("set_state"), st.lists(state, min_size=1, max_size=3)),
        st.tuples(st.just("prepare_advance"), vectors(n)),
        st.tuples(st.just("prepare"), vectors(n)),
        st.tuples(st.just("advance")),
        st.tuples(st.just("step"), vectors(n)),
        st.tuples(st.just("step_mapping"), st.dictionaries(st.integers(0, n), hostile(),
                                                             max_size=n)),
        st.tuples(st.just("restore"), st.integers(0, 3), hostile()),
        st.tuples(st.just("balance")),
        st.tuples(st.just("reset")),
        st.tuples(st.just("read")),
    )
    return st.lists(op, min_size=1, max_size=12)


@st.composite
def plant_program(draw: st.DrawFn) -> tuple[str, list[tuple[Any, ...]]]:
    arm = draw(arms)
    p = plant(arm)
    return arm, draw(operations(p.n, [s for s in p.state_names if s not in ("q", "qd")]))


def apply(p: Any, op: tuple[Any, ...]) -> None:
    kind = op[0]
    if kind == "set_state":
        values: dict[str, Any] = {}
        for name, value in op[1]:
            values[name] = value
        p.set_state(**values)
    elif kind == "prepare_advance":
        p.prepare(op[1])
        p.advance()
    elif kind == "prepare":
        p.prepare(op[1])
    elif kind == "advance":
        p.advance()
    elif kind == "step":
        p.step(op[1])
    elif kind == "step_mapping":
        names = [*p.joint_names, "nonesuch"]
        p.step({names[j]: v for j, v in op[1].items()})
    elif kind == "restore":
        state = p.save()
        size = [state.size, 0, state.size - 1, state.size + 1][op[1]]
        vector = np.resize(state, size)
        if size:
            vector[size // 2] = op[2]
        p.restore(vector)
    elif kind == "balance":
        p.balance_pressures()
    elif kind == "reset":
        p.reset()
    else:
        _ = (p.state(), p.record, p.tau_fric, p.tau_limit, p.modes, p.actuator_forces())


@fuzz_settings(EXAMPLES)
@given(program=plant_program())
def test_stepping(program: tuple[str, list[tuple[Any, ...]]]) -> None:
    """Sequences of set_state, prepare, advance, step, restore, balance_pressures, reset and
    reads with hostile values; after any refusal the sequence goes on."""
    arm, ops = program
    p = plant(arm)
    p.reset()
    for op in ops:
        try:
            apply(p, op)
            event(f"{op[0]}: done")
        except errors() as exc:
            event(f"{op[0]}: {type(exc).__name__}")
        except RuntimeError as exc:  # advance() without prepare(): refused in Python
            assert "prepare" in str(exc)
        except (TypeError, ValueError) as exc:  # mj_setState: a vector of the wrong size
            assert op[0] == "restore", exc


# --- runs ------------------------------------------------------------------------------------
class Controller:
    """A Python controller with a hostile period and hostile commands."""

    def __init__(self, dt: Any, commands: list[float]) -> None:
        self.dt = dt
        self.commands = commands

    def __call__(self, t: float, state: Any) -> list[float]:
        return self.commands


@st.composite
def run_case(draw: st.DrawFn) -> dict[str, Any]:
    arm = draw(arms)
    p = plant(arm)
    n = p.n
    # durations: a few hundred steps at most, or values that must be refused before a step
    steps = draw(st.integers(0, 300))
    duration = draw(st.one_of(st.just(steps * p.dt), st.just(steps * p.dt * 1.37),
                              st.just(steps * p.dt), st.sampled_from([0.0, -1.0, math.nan, math.inf, -math.inf,
                                               5e-324])))
    huge = draw(st.sampled_from([None] * 8 + [1e18, 1e300]))
    sample_dt = draw(st.one_of(st.none(), st.integers(1, 400).map(lambda k: k * p.dt),
                               st.none(),
                               st.sampled_from([0.0, -1.0, math.nan, math.inf, 5e-324,
                                                0.3 * p.dt])))
    if huge is not None:  # refused by the memory budget: only with the default interval
        duration, sample_dt = huge, None
    inputs = draw(st.dictionaries(st.integers(0, n - 1), st.one_of(
        ordinary(), ordinary(), ordinary(), st.sampled_from(HOSTILE)), max_size=n))
    controller = draw(st.one_of(
        st.none(), st.none(), st.builds(Controller, st.one_of(st.none(), st.sampled_from(
            [0.0, -1.0, math.nan, math.inf, "x", 0.3 * p.dt, p.dt, 7 * p.dt])), vectors(n))))
    continued = draw(st.booleans())
    return {"arm": arm, "duration": duration, "sample_dt": sample_dt, "inputs": inputs,
            "controller": controller, "continued": continued}


@fuzz_settings(EXAMPLES)
@given(case=run_case())
def test_runs(case: dict[str, Any]) -> None:
    """ml.simulate on a plant (a fresh start or going on from the last state) with hostile
    durations, sample intervals, inputs and controllers."""
    import maniplab as ml

    p = plant(case["arm"])
    if not case["continued"]:
        p.reset()
    inputs = {p.joint_names[j]: v for j, v in case["inputs"].items()}
    try:
        run = ml.simulate(p, duration=case["duration"], sample_dt=case["sample_dt"],
                          inputs=inputs, controller=case["controller"], progress=False)
    except errors() as exc:
        event(f"refused: {type(exc).__name__}")
        return
    event("ran")
    assert run.t.size >= 2 and np.isfinite(run.t).all()


# --- the known issues: each in a child process (fixed in 11060c8; xfail only on its report) ----
KNOWN = {
    # a step of 1e-308 s: the run's sample interval overflows the C loop's int64 (every = 0)
    "tiny-dt": ("division by zero", "ml.simulate('planar2', dt=1e-308, duration=1e-3)"),
}


def known_case(name: str) -> None:
    import maniplab as ml

    try:
        if name == "tiny-dt":
            ml.simulate("planar2", dt=1e-308, duration=1e-3, progress=False)
    except ml.ManiplabError:
        pass


@pytest.mark.parametrize("name", sorted(KNOWN))
def test_known(name: str) -> None:
    """A known defect (being fixed): xfail while the child stops with its known report,
    anything else must be clean."""
    proc = run_child([__file__, "--known", name])
    report = report_of(proc)
    signature, call = KNOWN[name]
    if report and signature in report:
        pytest.xfail(f"known: {call}: {report.splitlines()[0]}")
    assert proc.returncode == 0 and report is None, (report or proc.stderr[-3000:])


def test_prepare_refuses_nan() -> None:
    """Plant.prepare([nan] * n) is refused (it recorded a full reverse command before 11060c8)."""
    import maniplab as ml

    p = plant("crane3")
    p.reset()
    with pytest.raises(ml.ManiplabError):
        p.prepare([math.nan] * p.n)


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--known":
        reexec_sanitized()
        known_case(sys.argv[2])
        sys.exit(0)
    reexec_sanitized()
    sys.exit(pytest.main([__file__, "-q", "-p", "no:cacheprovider",
                          "-W", "ignore::pytest.PytestAssertRewriteWarning", *sys.argv[1:]]))
