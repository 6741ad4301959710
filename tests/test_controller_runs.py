"""A run starts from a reset controller, and a controller shared by runs at once is copied
(issues 40 finding 5 and 41 findings 1-2).

Before: ``simulate`` never reset the controller, so the same cascade run twice on one move gave
different runs; one ``CascadeController`` used by runs in several threads had its compiled log
buffers replaced under another thread's run (heap-use-after-free in ``ml_cascade_sample``, or a
spurious "the controller's log is full"); and a controller did not pickle.
"""

from __future__ import annotations

import copy
import pickle
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import maniplab as ml
from maniplab.control.cascade import CascadeController
from maniplab.control.trajectory import MinJerkMove, Pose
from maniplab.sim.errors import InputError

Q0 = np.array([-0.18, 1.27, 0.0, 0.0, 0.0, 0.0])


@pytest.fixture(scope="module")
def case() -> tuple[ml.ManipulatorSpec, CascadeController, dict]:
    spec = ml.builtin_spec("erector")
    am = ml.AnalyticModel(spec)
    start = Pose.from_matrix(am.fk(Q0))
    move = MinJerkMove(start, start.translated((-0.3, 0.15, 0.0)), 0.8, t0=0.1)
    controller = CascadeController(spec, move, model=am)
    return spec, controller, {"duration": 1.0, "initial": {"q": Q0, "dP": "gravity"}}


def alone(spec: ml.ManipulatorSpec, controller: CascadeController, kw: dict) -> ml.Run:
    """The run with a controller made afresh for it."""
    fresh = CascadeController(spec, controller.trajectory, model=controller.model)
    return ml.simulate(spec, controller=fresh, **kw)


def assert_same_run(a: ml.Run, b: ml.Run) -> None:
    for name in ("q", "qd", "ctrl", "dP", "x_d", "tau_d"):
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def test_the_same_controller_twice_gives_the_same_run(case) -> None:
    spec, controller, kw = case
    first = ml.simulate(spec, controller=controller, **kw)
    second = ml.simulate(spec, controller=controller, **kw)
    assert_same_run(first, second)
    assert_same_run(first, alone(spec, controller, kw))
    # the log shows this run's samples only, one per controller period from t = 0
    np.testing.assert_allclose(controller.times, np.arange(len(controller.times)) * controller.dt)


def test_a_controller_run_after_another_arm_gives_its_run_alone(case) -> None:
    """The sweep case: one object over variants (a +30 % payload first)."""
    spec, controller, kw = case
    heavy = spec.with_overrides({"end_effector.mass": 1.3 * spec.end_effector.mass})
    ml.simulate(heavy, controller=controller, **kw)
    assert_same_run(ml.simulate(spec, controller=controller, **kw), alone(spec, controller, kw))


def test_one_controller_in_four_threads_gives_each_run_its_run_alone(case) -> None:
    spec, controller, kw = case
    reference = alone(spec, controller, kw)
    with ThreadPoolExecutor(4) as pool:
        runs = list(pool.map(lambda _: ml.simulate(spec, controller=controller, **kw), range(8)))
    for run in runs:
        assert_same_run(run, reference)


def test_a_controller_pickles_and_copies_to_one_that_runs_the_same(case) -> None:
    spec, controller, kw = case
    reference = alone(spec, controller, kw)
    for other in (pickle.loads(pickle.dumps(controller)), copy.deepcopy(controller)):
        assert other is not controller and other._c.address != controller._c.address
        assert_same_run(ml.simulate(spec, controller=other, **kw), reference)


class Stateful:
    """A user's controller with a reset that takes the plant's state, and a lock (which cannot
    be copied) to check the refusal."""

    dt = 0.01

    def __init__(self, gate: threading.Event | None = None) -> None:
        self.gate, self.calls, self.started_at = gate, 0, None
        self.lock = threading.Lock()

    def reset(self, state) -> None:
        self.calls, self.started_at = 0, np.array(state.q)

    def __call__(self, t, state):
        self.calls += 1
        if self.gate is not None:
            assert self.gate.wait(60)
        return np.zeros(len(state.q))


def test_reset_gets_the_plant_state_at_the_start() -> None:
    user = Stateful()
    user.calls = 99
    ml.simulate("planar2", controller=user, duration=0.1, initial={"q": [0.3, -0.2]})
    assert user.calls == 10
    np.testing.assert_array_equal(user.started_at, [0.3, -0.2])


def test_a_controller_without_an_argument_to_reset_is_reset_too() -> None:
    class Counter:
        def __init__(self) -> None:
            self.calls = 0

        def reset(self) -> None:
            self.calls = 0

        def __call__(self, t, state):
            self.calls += 1
            return np.zeros(2)

    counter = Counter()
    for _ in range(2):
        ml.simulate("planar2", controller=counter, duration=0.01)
        assert counter.calls == 10


def test_a_busy_controller_that_cannot_be_copied_is_refused_in_one_line() -> None:
    gate = threading.Event()
    user = Stateful(gate)
    with ThreadPoolExecutor(1) as pool:
        first = pool.submit(ml.simulate, "planar2", controller=user, duration=0.05)
        for _ in range(6000):  # the first run holds the controller, waiting at its gate
            if user.calls:
                break
            time.sleep(0.01)
        with pytest.raises(InputError, match=r"controller Stateful is used by another run .* "
                                             r"give each thread its own controller"):
            ml.simulate("planar2", controller=user, duration=0.05)
        gate.set()
        first.result(timeout=60)
    ml.simulate("planar2", controller=user, duration=0.05)  # free again
