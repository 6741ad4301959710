"""Fuzzing the compiled cascade controller (cascade.c, linalg.c, valve.c) under ASan and UBSan.

- samples through the controller's ``step`` (ml_cascade_sample, ml_cascade_commit) in both modes
  on crane3 (valves, position task), planar2 (torque sources) and the erector (six valves, pose
  task), with hostile times (NaN, ±inf, backwards), states, pressures, resets and long runs of
  samples that grow the log;
- the native run's controller (ml_cascade_control) called through its C address with hostile
  schedules (unsorted, NaN, repeated, empty) and hostile MuJoCo states;
- closed-loop runs of ``ml.simulate`` with the native controller in the plant's loop;
- threads: separate controllers in four threads (each run equal to the same run alone), and one
  controller shared by four threads (a known defect: ``test_known_shared_controller``).

Run as a script (``python tests/sanitize/fuzz_cascade.py``) or with pytest in a sanitized
process (``python tests/sanitize/run.py``).
"""

from __future__ import annotations

import ctypes
import math
import sys
import threading
from functools import cache
from typing import Any

import numpy as np
import pytest
from hypothesis import event, given
from hypothesis import strategies as st
from sanitized import fuzz_settings, reexec_sanitized, report_of, run_child

EXAMPLES = 40

CASES = {
    # arm: (start q, end-effector offset (m))
    "crane3": ([0.0, -0.3, 0.5], (0.1, 0.05, 0.05)),
    "planar2": ([0.3, 0.15], (0.05, 0.0, 0.02)),
    "erector": ([-0.18, 1.27, 0.0, 0.0, 0.0, 0.0], (-0.1, 0.05, 0.0)),
}

HOSTILE = [math.nan, math.inf, -math.inf, 0.0, -0.0, 5e-324, 1e-308, 1e308, -1e308, 1e10,
           -1e10, 1.0, -1.0]

CONTROLLER = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_double, ctypes.c_void_p,
                              ctypes.c_void_p, ctypes.POINTER(ctypes.c_double))
"""plant.h's ml_controller_fn."""


@cache
def model(arm: str) -> Any:
    import maniplab as ml

    return ml.AnalyticModel(ml.resolve_spec(arm))


def controller(arm: str, mode: str = "cascade") -> Any:
    """A fresh controller moving the end effector from the case's start pose."""
    import maniplab as ml
    from maniplab.control import CascadeController, MinJerkMove, Pose

    q0, offset = CASES[arm]
    m = model(arm)
    start = Pose.from_matrix(m.fk(np.array(q0)))
    move = MinJerkMove(start, start.translated(offset), 0.3, t0=0.02)
    return CascadeController(ml.resolve_spec(arm), move, model=m, mode=mode)


def number() -> st.SearchStrategy[float]:
    return st.one_of(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), st.sampled_from(HOSTILE),
                     st.floats(allow_nan=True, allow_infinity=True))


def errors() -> tuple[type[BaseException], ...]:
    import maniplab as ml

    return (ml.ManiplabError,)


@st.composite
def sample_program(draw: st.DrawFn) -> tuple[str, str, list[tuple[Any, ...]]]:
    arm = draw(st.sampled_from(sorted(CASES)))
    n = len(CASES[arm][0])
    vec = st.lists(number(), min_size=n, max_size=n)
    op = st.one_of(
        st.tuples(st.just("step"), number(), vec, vec, vec),
        st.tuples(st.just("steps"), st.integers(1, 200)),
        st.tuples(st.just("reset")),
        st.tuples(st.just("signals")),
    )
    return arm, draw(st.sampled_from(["cascade", "pid"])), draw(st.lists(op, min_size=1,
                                                                         max_size=8))


@fuzz_settings(EXAMPLES)
@given(program=sample_program())
def test_samples(program: tuple[str, str, list[tuple[Any, ...]]]) -> None:
    """The controller's step with hostile times, states and pressures; runs of many samples
    (the log grows); resets; the log read back."""
    arm, mode, ops = program
    c = controller(arm, mode)
    q0 = np.array(CASES[arm][0])
    t = 0.0
    for op in ops:
        try:
            if op[0] == "step":
                cmd = c.step(op[1], np.array(op[2]), np.array(op[3]), dP=np.array(op[4]))
                assert cmd.shape == (c.n,)
            elif op[0] == "steps":
                for _ in range(op[1]):
                    c.step(t, q0, np.zeros(c.n), dP=np.zeros(c.n))
                    t += c.dt
            elif op[0] == "reset":
                c.reset()
            else:
                c.signals()
            event(f"{op[0]}: done")
        except errors() as exc:
            event(f"{op[0]}: {type(exc).__name__}")


@st.composite
def schedules(draw: st.DrawFn) -> tuple[str, list[float], list[float], list[tuple[Any, ...]]]:
    arm = draw(st.sampled_from(sorted(CASES)))
    n = len(CASES[arm][0])
    times = draw(st.one_of(
        st.integers(0, 50).map(lambda k: [i * 0.01 for i in range(k)]),
        st.lists(number(), max_size=20)))
    calls = draw(st.lists(st.one_of(st.sampled_from([0.0, 0.01, 0.02, 0.5]), number()),
                          min_size=1, max_size=30))
    state = draw(st.lists(st.tuples(st.sampled_from(["qpos", "qvel", "act"]),
                                    st.integers(0, 3 * n), number()), max_size=4))
    return arm, times, calls, state


@fuzz_settings(EXAMPLES)
@given(case=schedules())
def test_native_control(case: tuple[str, list[float], list[float], list[tuple[Any, ...]]]
                        ) -> None:
    """ml_cascade_control through its C address (as the plant's loop calls it) with a hostile
    schedule, hostile call times and hostile MuJoCo states."""
    import mujoco

    import maniplab as ml

    arm, times, calls, state = case
    c = controller(arm)
    plant = ml.Plant(arm)
    native = c.native(plant, np.array(times))
    assert native is not None
    data = mujoco.MjData(plant.model)
    data.qpos[:] = CASES[arm][0]
    for name, index, value in state:
        array = getattr(data, name)
        if array.size:
            array[index % array.size] = value
    function = CONTROLLER(native.function)
    u = (ctypes.c_double * c.n)()
    for t in calls:
        status = function(native.context, t, plant.model._address, data._address, u)
        event(f"status {status}")
    _ = c.signals()


@fuzz_settings(EXAMPLES // 4)
@given(arm=st.sampled_from(sorted(CASES)), mode=st.sampled_from(["cascade", "pid"]),
       duration=st.sampled_from([0.001, 0.05, 0.2]),
       q=st.lists(st.floats(-0.5, 0.5), min_size=6, max_size=6))
def test_closed_loop(arm: str, mode: str, duration: float, q: list[float]) -> None:
    """ml.simulate with the native controller in the plant's loop, from a perturbed start."""
    import maniplab as ml

    c = controller(arm, mode)
    q0 = np.array(CASES[arm][0]) + np.array(q[:len(CASES[arm][0])])
    try:
        run = ml.simulate(arm, controller=c, duration=duration, initial={"q": q0},
                          progress=False)
        event("ran")
        assert np.isfinite(run.t).all()
    except errors() as exc:
        event(f"refused: {type(exc).__name__}")


# --- threads ---------------------------------------------------------------------------------
def closed_loop(arm: str, c: Any, duration: float = 0.15) -> dict[str, np.ndarray]:
    import maniplab as ml

    run = ml.simulate(arm, controller=c, duration=duration, initial={"q": CASES[arm][0]},
                      progress=False)
    return {k: np.array(run[k]) for k in ("q", "qd", "ctrl")}


def in_threads(work: list[Any]) -> list[Any]:
    """Run the callables at once, one thread each; their results (or exceptions)."""
    results: list[Any] = [None] * len(work)
    start = threading.Barrier(len(work))

    def main(i: int) -> None:
        start.wait()
        try:
            results[i] = work[i]()
        except BaseException as exc:  # noqa: BLE001 (reported by the caller)
            results[i] = exc

    threads = [threading.Thread(target=main, args=(i,)) for i in range(len(work))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    return results


def same(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> bool:
    return all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)


ARMS_THREADS = ["crane3", "planar2", "crane3", "erector"]


def test_threads_separate_controllers() -> None:
    """Four threads, each with its own controller and plant, at once: each run equal to the same
    run alone."""
    alone = [closed_loop(arm, controller(arm)) for arm in ARMS_THREADS]
    together = in_threads([lambda arm=arm: closed_loop(arm, controller(arm))
                           for arm in ARMS_THREADS])
    for arm, a, b in zip(ARMS_THREADS, alone, together):
        assert not isinstance(b, BaseException), b
        assert same(a, b), arm


def shared_controller_case() -> None:
    """One controller shared by four threads' runs of crane3 at once; each run must equal the
    run alone (or be refused with one of maniplab's errors)."""
    import maniplab as ml

    c = controller("crane3")
    alone = closed_loop("crane3", c)
    together = in_threads([lambda: closed_loop("crane3", c) for _ in range(4)])
    for b in together:
        if isinstance(b, ml.ManiplabError):
            continue
        assert not isinstance(b, BaseException), b
        assert same(alone, b)


def test_known_shared_controller() -> None:
    """One CascadeController shared by runs in four threads (the known defect, being fixed:
    CompiledCascade.reserve replaces the log's buffers while another thread's run writes through
    the old ones: heap-use-after-free in ml_cascade_sample). In a child process: xfail while the
    child stops with that report, anything else must pass."""
    proc = run_child([__file__, "--shared"])
    report = report_of(proc)
    if report and "heap-use-after-free" in report and "ml_cascade" in report:
        pytest.xfail("known: one controller shared by threads: " + report.splitlines()[0])
    assert proc.returncode == 0 and report is None, (report or proc.stderr[-3000:])


if __name__ == "__main__":
    reexec_sanitized()
    if sys.argv[1:] == ["--shared"]:
        shared_controller_case()
        sys.exit(0)
    sys.exit(pytest.main([__file__, "-q", "-p", "no:cacheprovider",
                          "-W", "ignore::pytest.PytestAssertRewriteWarning", *sys.argv[1:]]))
