"""MuJoCo's process-global actuator callbacks and maniplab's one dispatcher (maniplab.mjcb):
foreign models in other threads see exactly what MuJoCo alone gives them (with no callback or
with the user's own), plants with Python actuators get theirs, and plants in several threads run
concurrently. Also: LuGre's bristle force is part of the recorded friction."""

from __future__ import annotations

import ctypes
import subprocess
import sys
import threading
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
import pytest
from plugins.dcmotor import GearedDCMotor

import maniplab as ml

# A plain MuJoCo model: actuator 0 has user dynamics and bias, actuator 1 is a motor. Run here in
# a thread and, as the reference, in a fresh process that never imports maniplab.
FOREIGN = '''
import mujoco
import numpy as np

XML = """
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <body pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03" mass="1"/>
    </body>
  </worldbody>
  <actuator>
    <general name="user" joint="hinge" dyntype="user" biastype="user" gaintype="fixed"
             gainprm="1"/>
    <motor name="motor" joint="hinge"/>
  </actuator>
</mujoco>
"""
MODEL = mujoco.MjModel.from_xml_string(XML)  # compiling calls the callbacks: before any is set


def user_dyn(m, d, i):
    return -5.0 * d.act[0] + d.ctrl[0]


def user_bias(m, d, i):
    return -0.1 * d.qvel[0]


def set_user_callbacks():
    mujoco.set_mjcb_act_dyn(user_dyn)
    mujoco.set_mjcb_act_bias(user_bias)


def trajectory(steps):
    """(steps, 3): qpos, qvel, act after each mj_step, with the callbacks installed."""
    m = MODEL
    d = mujoco.MjData(m)
    d.act[0] = 0.3
    out = np.empty((steps, 3))
    for k in range(steps):
        d.ctrl[:] = [np.sin(1e-3 * k), 0.2 * np.cos(2e-3 * k)]
        mujoco.mj_step(m, d)
        out[k] = d.qpos[0], d.qvel[0], d.act[0]
    return out
'''

_foreign: dict[str, Any] = {}
exec(FOREIGN, _foreign)  # noqa: S102 - the same source the reference process runs
trajectory: Callable[[int], np.ndarray] = _foreign["trajectory"]

MOTOR = {"resistance": 1.0, "inductance": 5e-3, "torque_constant": 0.05, "gear_ratio": 20.0}


def motor_arm(actuator: str = "plugins.dcmotor:GearedDCMotor") -> ml.ManipulatorSpec:
    """One joint driven by a Python actuator (a DC motor computed through the callbacks)."""
    return ml.ManipulatorSpec.from_dict({
        "name": "motor-arm",
        "joints": [{"name": "j", "type": "R", "axis": "z", "body": {"length": 0.5, "mass": 2.0},
                    "actuator": {"type": actuator, **MOTOR}, "friction": {"viscous": 0.02}}],
    })


def motor_run() -> np.ndarray:
    return ml.simulate(motor_arm(), inputs={"j": 12.0}, duration=0.02).q


def reference(steps: int, user_callbacks: bool, tmp_path: Any) -> np.ndarray:
    """The foreign trajectory in a fresh process with no maniplab."""
    out = tmp_path / "foreign.npy"
    code = (FOREIGN + ("\nset_user_callbacks()" if user_callbacks else "")
            + f"\nnp.save({str(out)!r}, trajectory({steps}))\n"
            "import sys\nassert 'maniplab' not in sys.modules\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)
    return np.load(out)


def alongside_plants(steps: int, user_callbacks: bool) -> tuple[np.ndarray, int]:
    """The foreign trajectory stepped in a thread while plants with a Python actuator run in this
    one (each equal to the same run alone); and how many runs overlapped it. The user's callbacks
    are set before (setting them while another thread compiles a model is a race of theirs)."""
    alone = motor_run()
    if user_callbacks:
        _foreign["set_user_callbacks"]()
    result: dict[str, Any] = {}
    runs = [0]
    started = threading.Event()

    def foreign() -> None:
        try:
            started.wait(timeout=60)
            before = runs[0]
            result["trajectory"] = trajectory(steps)
            result["overlapped"] = runs[0] - before
        except BaseException as exc:  # noqa: BLE001 - asserted below
            result["error"] = exc

    thread = threading.Thread(target=foreign)
    thread.start()
    started.set()
    while thread.is_alive():
        np.testing.assert_array_equal(motor_run(), alone)
        runs[0] += 1
    thread.join()
    assert "error" not in result, result.get("error")
    return result["trajectory"], result["overlapped"]


@pytest.fixture
def no_user_callbacks():
    """Whatever a test installs as the user is removed after it."""
    yield
    mujoco.set_mjcb_act_dyn(None)
    mujoco.set_mjcb_act_bias(None)


def test_a_foreign_model_in_a_thread_sees_no_change(tmp_path, no_user_callbacks) -> None:
    steps = 100_000
    stepped, overlapped = alongside_plants(steps, user_callbacks=False)
    assert overlapped >= 2
    np.testing.assert_array_equal(stepped, reference(steps, False, tmp_path))
    assert stepped[-1, 2] == 0.3  # no callback: the user actuator's state never moved


def test_the_users_callbacks_keep_serving_a_foreign_model(tmp_path, no_user_callbacks) -> None:
    """Set by the user with mujoco.set_mjcb_act_*: they serve the foreign model in its thread
    (also while this thread compiles plants' models), the plants get their Python actuator."""
    steps = 60_000
    stepped, overlapped = alongside_plants(steps, user_callbacks=True)
    assert overlapped >= 2
    expected = reference(steps, True, tmp_path)
    np.testing.assert_array_equal(stepped, expected)
    assert abs(expected[-1, 2] - 0.3) > 0.1  # the user's dynamics moved the state
    assert mujoco.get_mjcb_act_dyn() is _foreign["user_dyn"]


ACT_FN = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int)


def recorder(calls: list[Any], entry: Any) -> Callable[[Any, Any, int], float]:
    """An actuator callback that appends ``entry`` (or the actuator id, for None) and returns 0."""
    def callback(m: Any, d: Any, i: int) -> float:
        calls.append(i if entry is None else entry)
        return 0.0
    return callback


def test_a_callback_set_later_is_chained_and_the_plants_still_get_theirs(
        no_user_callbacks) -> None:
    """The user replaces maniplab's dispatcher (a Python callback: the bindings' trampoline; then
    a ctypes one: its own C pointer); the next plant run installs it again, chaining to it."""
    alone = motor_run()
    calls: list[str] = []
    c_function = ACT_FN(recorder(calls, "ctypes"))
    for name, callback in (("python", recorder(calls, "python")), ("ctypes", c_function)):
        mujoco.set_mjcb_act_dyn(callback)
        np.testing.assert_array_equal(motor_run(), alone)  # the dispatcher is back for its run
        assert not calls  # the user's callback never saw the plant's model
        trajectory(1)  # a foreign model, after maniplab's run: the user's callback
        assert calls == [name]
        calls.clear()


def test_a_users_callback_is_not_called_while_maniplab_compiles(no_user_callbacks) -> None:
    seen: list[int] = []
    mujoco.set_mjcb_act_dyn(recorder(seen, None))
    assert ml.build_model(motor_arm()).nu == 1
    np.testing.assert_array_equal(trajectory(2)[:, 2], [0.3, 0.3])  # user_dyn not set
    assert seen == [0, 0]  # the foreign model's steps only


# --- plants in threads run concurrently ------------------------------------------------------
class _FirstCallBarrier:
    """Each thread waits for the other two at its first call: if the three ran one after
    another, the first would wait alone and the barrier break (threading.BrokenBarrierError)."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.barrier = threading.Barrier(3, timeout=10)
        self.waited = threading.local()

    def wait(self) -> None:
        if not getattr(self.waited, "done", False):
            self.waited.done = True
            self.barrier.wait()


BARRIER = _FirstCallBarrier()


class BarrierMotor(GearedDCMotor):
    """The DC motor, whose first force in each thread waits on :data:`BARRIER`."""

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        BARRIER.wait()
        return super().force(x, u, q, v)


def in_three_threads(work: Callable[[int], Any]) -> list[Any]:
    results: list[Any] = [None] * 3

    def run(k: int) -> None:
        try:
            results[k] = work(k)
        except BaseException as exc:  # noqa: BLE001 - asserted below
            results[k] = exc

    threads = [threading.Thread(target=run, args=(k,)) for k in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for result in results:
        assert not isinstance(result, BaseException), result
    return results


def test_plants_with_python_actuators_in_three_threads_run_concurrently() -> None:
    BARRIER.reset()
    spec = motor_arm(f"{__name__}:BarrierMotor")
    runs = in_three_threads(lambda k: ml.simulate(spec, inputs={"j": 12.0}, duration=0.02).q)
    assert not BARRIER.barrier.broken
    alone = motor_run()
    for q in runs:
        np.testing.assert_array_equal(q, alone)


def test_native_plants_in_three_threads_run_concurrently() -> None:
    """No Python actuator: the only Python is each run's controller, which waits for the others
    at its first call (a plant that held a process-wide lock for its run would break it)."""
    barrier = _FirstCallBarrier()
    specs = ["crane3", "erector", "crane3"]

    def work(k: int) -> np.ndarray:
        def hold(t: float, state: ml.PlantState) -> np.ndarray:
            barrier.wait()
            return np.zeros(state.q.shape)

        return ml.simulate(specs[k], controller=hold, duration=0.05).q

    runs = in_three_threads(work)
    assert not barrier.barrier.broken
    np.testing.assert_array_equal(runs[0], runs[2])
    np.testing.assert_array_equal(runs[0], ml.simulate("crane3", inputs={}, duration=0.05).q)


# --- LuGre's bristle force in the record -----------------------------------------------------
SIGMA0, SIGMA1, SIGMA2, FC, FS, VS, MASS, K, VP = 1e5, 1e5**0.5, 0.4, 1.0, 1.5, 1e-3, 1.0, 2.0, 0.1


def lugre_block() -> ml.ManipulatorSpec:
    """The 1995 LuGre paper's 1 kg block (its Table I), pulled through a spring (see
    tests/test_friction_lugre.py); it sticks, then slips from t ≈ 7.5 s."""
    friction = {"model": "lugre", "coulomb": FC, "static": FS - FC, "viscous": SIGMA2,
                "stribeck_velocity": VS, "sigma0": SIGMA0, "sigma1": SIGMA1}
    return ml.ManipulatorSpec.from_dict({"name": "block", "joints": [
        {"name": "x", "type": "P", "axis": "x", "body": {"mass": MASS}, "friction": friction}]})


def test_tau_fric_is_the_lugre_force_applied() -> None:
    """tau_fric of a LuGre joint at t_k is the force MuJoCo applied at the start of step k:
    -(σ0 z + σ1 ż) - σ2 q̇ (bristles and viscous part), as the closed form gives it from the
    recorded state, as MuJoCo computes it on a replay, and as the block's equation of motion
    m q̈ = u + tau_fric needs it (q̈ from the recorded q̇; RK4 averages the force over a step, the
    record takes its start: within 5 % of the largest force at the fastest changes)."""
    dt = 1e-3
    run = ml.simulate(lugre_block(), controller=lambda t, s: [K * (VP * t - s.q[0])],
                      duration=10.0, sample_dt=dt)
    qd, z, fric, u = run.qd[:-1, 0], run["z"][:-1, 0], run["tau_fric"][:-1, 0], run["ctrl"][:-1, 0]
    g = FC + (FS - FC) * np.exp(-((qd / VS) ** 2))
    zdot = qd - SIGMA0 * np.abs(qd) * z / g
    np.testing.assert_allclose(fric, -(SIGMA0 * z + SIGMA1 * zdot) - SIGMA2 * qd,
                               rtol=1e-12, atol=1e-12)
    peak = np.max(np.abs(fric))
    assert peak > 1.4  # the break-away force Fs = 1.5 N is reached
    plant = ml.Plant(lugre_block())
    model = plant.model
    data = mujoco.MjData(model)
    lugre = model.actuator("x/lugre").id
    for k in range(0, len(qd), 97):
        data.qpos[0], data.qvel[0] = run.q[k, 0], qd[k]
        data.act[model.actuator_actadr[lugre]] = z[k]
        mujoco.mj_forward(model, data)
        applied = data.actuator_force[lugre] - SIGMA2 * qd[k]
        assert applied == pytest.approx(fric[k], rel=1e-12, abs=1e-12)
    residual = MASS * np.diff(run.qd[:, 0]) / dt - (u + fric)
    assert np.max(np.abs(residual)) < 0.05 * peak
    assert np.percentile(np.abs(residual), 99) < 1e-3 * peak


def test_mujocos_profiling_clock_is_off_while_a_plant_runs_and_restored_after() -> None:
    """The user's mjcb_time is not called from a plant's steps (its two reads per stage cost
    7-10 % of a run) and is back in place afterwards, for plain MuJoCo."""
    calls: list[int] = []

    def clock() -> float:
        calls.append(1)
        return float(len(calls))

    saved = mujoco.get_mjcb_time()
    mujoco.set_mjcb_time(clock)
    try:
        plant = ml.Plant("patu655")
        calls.clear()  # (building the plant runs MuJoCo outside a plant's steps)
        ml.simulate(plant, inputs={"lift": 0.3}, duration=0.05)
        assert calls == [] and mujoco.get_mjcb_time() is clock
        mujoco.mj_step(plant._model, mujoco.MjData(plant._model))
        assert len(calls) > 0  # plain MuJoCo reads it again
    finally:
        mujoco.set_mjcb_time(saved)
