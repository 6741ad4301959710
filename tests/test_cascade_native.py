"""The cascade's sample in C (maniplab_native/cascade.c) against the frozen Python sample it
replaced (tests/reference/cascade.py).

Closed loops on MuJoCo run the C function the plant's run loop calls (``controller.native``,
driven here through ctypes with the MjData of ``ml.build_model``) on the built-in arms and the
corpus arms in both modes; the frozen Python cascade, fed the same states, logs the same signals
to round-off: 1e-12 relative, with a slack of 1e-11 of each signal's largest value where a value
crosses zero (the two compute in different orders: BLAS and LAPACK against plain loops and a
Jacobi SVD). The runs include samples where valves saturate and where the least squares damp a
near-singular Jacobian. The Python path (``step``) runs the same C code: bit for bit the native
run. Drives written in Python (a plugin's DC motor) get their commands from Python."""

from __future__ import annotations

import ctypes
from pathlib import Path

import mujoco
import numpy as np
import pytest
from reference.cascade import ReferenceCascade

import maniplab as ml
from maniplab.control import CascadeController, Hold, MinJerkMove, Pose, rotation_exp
from maniplab.spec import model_of

ARMS = Path(__file__).parent / "arms"
RTOL, SLACK = 1e-12, 1e-11

CONTROLLER = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_double, ctypes.c_void_p,
                              ctypes.c_void_p, ctypes.POINTER(ctypes.c_double))
"""plant.h's ml_controller_fn."""

# name: (spec, start q, end-effector offset (m), move duration (s), samples)
CASES = {
    "erector": ("erector", [-0.18, 1.27, 0.0, 0.0, 0.0, 0.0], (-0.1, 0.05, 0.0), 1.0, 300),
    "erector-fast": ("erector", [-0.18, 1.27, 0.0, 0.0, 0.0, 0.0], (-0.3, 0.3, 0.1), 0.3, 200),
    "crane3": ("crane3", [0.0, -0.3, 0.5], (0.1, 0.05, 0.05), 0.4, 300),
    "planar2": ("planar2", [0.3, 0.15], (0.05, 0.0, 0.02), 0.8, 300),  # nearly stretched
    "excavator": (ARMS / "excavator.yaml", [0.0, -0.3, 0.3, 0.0], (0.1, 0.05, -0.05), 1.0, 300),
    "gantry": (ARMS / "gantry.yaml", [2.0, 1.0, -1.0], (0.1, 0.1, -0.05), 1.0, 300),
    "erector7": (ARMS / "erector7.yaml", [-0.18, 1.27, 0.0, 0.0, 0.0, 0.0, 0.0],
                 (-0.1, 0.05, 0.0), 1.0, 300),
    "electric2": (ARMS / "electric2.yaml", [-0.5, 1.0], (0.1, 0.0, 0.1), 0.8, 300),
    "loader-crane": (ARMS / "loader_crane.yaml", [0.0, -0.6, 1.2, 0.5], (0.1, 0.05, 0.05), 0.4,
                     300),
    # pinned cylinders: their drive in C since issue 36 (slew lumped, lift and tilt pinned)
    "patu655": ("patu655", [0.0, -0.3, 1.2], (0.1, 0.05, -0.05), 0.6, 300),
    "knuckle-crane": (ARMS / "knuckle_crane.yaml", [-1.29, -0.44, 1.48, 0.77, 0.0],
                      (0.1, 0.1, 0.05), 0.6, 300),
}

State = tuple[float, np.ndarray, np.ndarray, dict[str, np.ndarray]]


def controller_for(name: str, mode: str, **settings: object
                   ) -> tuple[CascadeController, list[float], int]:
    source, q0, offset, duration, samples = CASES[name]
    spec = ml.resolve_spec(str(source))
    model = ml.AnalyticModel(spec)
    start = Pose.from_matrix(model.fk(np.array(q0)))
    move = MinJerkMove(start, start.translated(offset), duration, t0=0.05)
    return CascadeController(spec, move, model=model, mode=mode, **settings), q0, samples


def held_against_gravity(controller: CascadeController, q0: list[float]
                         ) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The arm's MuJoCo model at q0, each actuator's states holding gravity."""
    spec = controller.spec
    m = ml.build_model(spec)
    d = mujoco.MjData(m)
    d.qpos[:] = q0
    gravity = controller.model.G(np.array(q0, dtype=float))
    for j, joint in enumerate(spec.joints):
        if m.actuator_actnum[j]:
            adr = m.actuator_actadr[j]
            d.act[adr:adr + m.actuator_actnum[j]] = model_of(joint).holding(gravity[j], q0[j])
    mujoco.mj_forward(m, d)
    return m, d


def pressures(m: mujoco.MjModel, d: mujoco.MjData, spec: ml.ManipulatorSpec
              ) -> dict[str, np.ndarray]:
    """The actuators' states by name (dP of a lumped cylinder, pA and pB of a pinned one...),
    each (n,), NaN at joints without that state."""
    out: dict[str, np.ndarray] = {}
    for j, joint in enumerate(spec.joints):
        for i, name in enumerate(model_of(joint).states):
            out.setdefault(name, np.full(spec.n, np.nan))[j] = d.act[m.actuator_actadr[j] + i]
    return out


def closed_loop(controller: CascadeController, q0: list[float], samples: int) -> list[State]:
    """The loop closed on MuJoCo through the native controller, as the plant's run loop calls
    it; the states it was called with."""
    m, d = held_against_gravity(controller, q0)
    steps = round(controller.dt / m.opt.timestep)
    times = np.arange(samples) * steps * m.opt.timestep
    native = controller.native(None, times)
    assert native is not None
    function = CONTROLLER(native.function)
    u = np.zeros(controller.n)
    states = []
    for t in times:
        d.time = t
        states.append((float(t), d.qpos.copy(), d.qvel.copy(), pressures(m, d, controller.spec)))
        status = function(native.context, t, m._address, d._address,
                          u.ctypes.data_as(ctypes.POINTER(ctypes.c_double)))
        assert status == 0, native.message()
        d.ctrl[:] = u
        mujoco.mj_step(m, d, nstep=steps)
    assert native.status == 0 and native.samples == samples
    return states


def assert_same(got: dict[str, np.ndarray], want: dict[str, np.ndarray]) -> None:
    assert set(got) == set(want)
    for name, expected in want.items():
        actual = got[name]
        assert actual.shape == expected.shape, name
        assert np.array_equal(np.isnan(actual), np.isnan(expected)), name
        finite = np.isfinite(expected)
        scale = float(np.max(np.abs(expected[finite]))) if finite.any() else 0.0
        np.testing.assert_allclose(actual, expected, rtol=RTOL, atol=SLACK * scale,
                                   equal_nan=True, err_msg=name)


def reference_of(controller: CascadeController, states: list[State]) -> ReferenceCascade:
    reference = ReferenceCascade(controller)
    for t, q, qd, actuators in states:
        reference.step(t, q, qd, **actuators)
    return reference


@pytest.mark.parametrize("mode", ["cascade", "pid"])
@pytest.mark.parametrize("name", CASES)
def test_the_native_closed_loop_equals_the_frozen_python_cascade(name: str, mode: str) -> None:
    controller, q0, samples = controller_for(name, mode)
    states = closed_loop(controller, q0, samples)
    reference = reference_of(controller, states)
    assert_same(controller.signals(), reference.signals())
    np.testing.assert_array_equal(controller.times, reference.times)
    saturated = np.any(np.abs(reference.signals()["cmd"]) >= controller._limit, axis=1)
    if name == "erector-fast":  # the valves saturate (and the outer integrator freezes)
        assert saturated.sum() > samples / 2
    if name == "planar2":  # near the stretched arm's singularity the least squares damp
        assert np.count_nonzero(reference.lam2) > samples / 2


SETTINGS = {
    "filtered derivative, unweighted": {"derivative_filter": 0.02, "capacity_weighting": False},
    "no feed-forward, no null-space damping": {"coulomb_feedforward": False, "null_damping": 0.0},
    "pressure integral and speed term": {
        "pressure": ml.spec.PressureGains(integral=20.0, speed_gain=0.7, rate_filter=0.0)},
    "damped everywhere": {"dls_threshold": 2.0, "dls_damping": 0.3, "valve_min_root": 0.3},
    "joint PID without integrator": {"pid_only": ml.spec.JointPIDGains(ki=0.0)},
}


@pytest.mark.parametrize("mode", ["cascade", "pid"])
@pytest.mark.parametrize("name", ["erector7", "excavator"])
@pytest.mark.parametrize("what", SETTINGS)
def test_every_setting_is_computed_as_the_blocks_compute_it(what: str, name: str,
                                                            mode: str) -> None:
    controller, q0, _ = controller_for(name, mode, **SETTINGS[what])
    states = closed_loop(controller, q0, 120)
    reference = reference_of(controller, states)
    assert_same(controller.signals(), reference.signals())
    if what == "damped everywhere":
        assert all(lam > 0.0 for lam in reference.lam2)


@pytest.mark.parametrize("mode", ["cascade", "pid"])
def test_the_python_path_runs_the_same_code_bit_for_bit(mode: str) -> None:
    native, q0, samples = controller_for("excavator", mode)
    states = closed_loop(native, q0, samples)
    stepped, _, _ = controller_for("excavator", mode)
    commands = [stepped.step(t, q, qd, **actuators) for t, q, qd, actuators in states]
    for name, values in native.signals().items():
        np.testing.assert_array_equal(stepped.signals()[name], values, err_msg=name)
    np.testing.assert_array_equal(np.array(commands), native.signals()["cmd"])


def test_native_samples_follow_python_ones_in_the_log() -> None:
    """A native run continues the controller's state and log like calling it would."""
    controller, q0, _ = controller_for("crane3", "cascade")
    twin, _, _ = controller_for("crane3", "cascade")
    m, d = held_against_gravity(controller, q0)
    actuators = pressures(m, d, controller.spec)
    for k in range(3):  # three samples in Python, then three native ones
        for c in (controller, twin):
            c(k * controller.dt, {"q": d.qpos, "qd": d.qvel, **actuators})
    times = np.arange(3, 6) * controller.dt
    native = controller.native(None, times)
    assert native is not None
    function = CONTROLLER(native.function)
    u = np.zeros(3)
    for t in times:
        d.time = t
        assert function(native.context, t, m._address, d._address,
                        u.ctypes.data_as(ctypes.POINTER(ctypes.c_double))) == 0
        np.testing.assert_array_equal(u, twin(t, {"q": d.qpos, "qd": d.qvel, **actuators}))
    np.testing.assert_array_equal(controller.times, twin.times)
    at = controller.signals_at(np.array([-1.0, 0.0, 4.5 * controller.dt, 10.0]))
    assert np.isnan(at["ctrl.cmd"][0]).all()
    np.testing.assert_array_equal(at["ctrl.cmd"][2], twin.signals()["cmd"][4])
    np.testing.assert_array_equal(at["ctrl.dP_d"][3], twin.signals()["dP_d"][5])
    controller.reset()
    assert controller.signals()["cmd"].shape == (0, 3) and len(controller.times) == 0


def test_the_native_controller_refuses_calls_off_its_schedule_and_non_finite_commands() -> None:
    controller, q0, _ = controller_for("crane3", "cascade")
    m, d = held_against_gravity(controller, q0)
    native = controller.native(None, np.array([0.0, controller.dt]))
    assert native is not None
    function = CONTROLLER(native.function)
    u = np.zeros(3)
    out = u.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
    assert function(native.context, 0.5 * controller.dt, m._address, d._address, out) != 0
    assert "not scheduled" in (native.message() or "")
    d.qvel[1] = np.nan
    assert function(native.context, controller.dt, m._address, d._address, out) != 0
    assert "NaN or infinite" in (native.message() or "") and not np.isfinite(u).all()
    with pytest.raises(ml.control.errors.ControlError, match="joints"):
        controller.native(ml.Plant(ml.builtin_spec("planar2")), np.zeros(1))


@pytest.mark.parametrize("angle", [0.0, 1e-8, 1e-4, 0.7, np.pi - 2e-4, np.pi - 1e-6, np.pi])
def test_orientation_errors_take_every_branch_of_the_rotation_log(angle: float) -> None:
    spec = ml.builtin_spec("erector")
    model = ml.AnalyticModel(spec)
    q = np.array([-0.18, 1.27, 0.3, 0.2, -0.4, 0.5])
    pose = Pose.from_matrix(model.fk(q))
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    target = Pose(pose.position, rotation_exp(angle * axis) @ pose.rotation)
    controller = CascadeController(spec, Hold(target, 1.0), model=model)
    reference = ReferenceCascade(controller)
    qd, dP = np.full(6, 0.01), np.full(6, 1e6)
    for k in range(3):
        controller.step(k * controller.dt, q, qd, dP=dP)
        reference.step(k * controller.dt, q, qd, dP=dP)
    got, want = controller.signals()["e_x"], reference.signals()["e_x"]
    # At pi the log's axis comes from sqrt((R + Rᵀ)/2 + ...), whose slope is infinite there: a
    # rounding difference eps in R moves it by about sqrt(eps) ~ 1e-8. Elsewhere it is smooth.
    atol = 1e-7 if angle > np.pi - 1e-5 else 1e-13
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=atol)
    assert np.linalg.norm(want[0, 3:]) == pytest.approx(angle, abs=1e-7)  # acos near pi


R, K, N, ETA = 1.0, 0.05, 100.0, 0.9


def motor_arm() -> ml.ManipulatorSpec:
    """test_drive's two-link arm on geared DC motors (a plugin whose drive is Python's)."""
    motor = {"type": "plugins.dcmotor:GearedDCMotor", "resistance": R, "inductance": 2e-3,
             "torque_constant": K, "gear_ratio": N, "efficiency": ETA, "voltage_limit": 48.0}
    link = {"type": "R", "axis": "y", "body": {"length": 0.5, "mass": 2.0}, "actuator": motor,
            "friction": {"model": "hybrid", "viscous": 0.5}}
    return ml.ManipulatorSpec.from_dict({"name": "motor-arm", "joints": [
        {"name": "shoulder", **link}, {"name": "elbow", **link}], "end_effector": {"mass": 1.0}})


@pytest.mark.parametrize("mode", ["cascade", "pid"])
def test_python_drives_finish_the_compiled_sample(mode: str) -> None:
    """The DC motors' volts come from their Python drive, on the forces (or speeds) the C sample
    left: the same as the frozen cascade's, in a loop closed on MuJoCo through the motors'
    steady torque."""
    spec = motor_arm()
    model = ml.AnalyticModel(spec)
    q0 = np.array([0.3, 1.2])
    start = Pose.from_matrix(model.fk(q0))
    move = MinJerkMove(start, start.translated([0.05, 0.0, 0.04]), 0.5, t0=0.05)
    controller = CascadeController(spec, move, model=model, mode=mode)
    assert controller.native(None, np.zeros(1)) is None  # the run loop calls it in Python
    reference = ReferenceCascade(controller)
    m = ml.build_model(spec)
    m.opt.timestep = controller.dt / 5
    d = mujoco.MjData(m)
    d.qpos[:] = q0
    for k in range(200):
        t = k * controller.dt
        state = (d.qpos.copy(), d.qvel.copy())
        volts = controller.step(t, *state)
        np.testing.assert_allclose(volts, reference.step(t, *state), rtol=RTOL, atol=1e-12)
        d.qfrc_applied[:] = ETA * N * K * (volts - K * N * d.qvel) / R  # the steady current
        mujoco.mj_step(m, d, nstep=5)
    assert_same(controller.signals(), reference.signals())
    if mode == "cascade":  # the loop really closes: 1 mm after a 64 mm move
        assert np.linalg.norm(controller.signals()["e_x"][-1, :3]) < 1e-3


class PythonOnly:
    """The controller without its native form: the run loop calls it back in Python."""

    def __init__(self, controller: CascadeController) -> None:
        self.controller, self.dt = controller, controller.dt

    def __call__(self, t: float, state: object) -> np.ndarray:
        return self.controller(t, state)


def test_simulate_runs_the_native_controller_as_the_python_one() -> None:
    """ml.simulate runs the cascade inside the plant's C loop; called back in Python instead it
    gives the same run, bit for bit, and the same log."""
    inside, q0, _ = controller_for("crane3", "cascade")
    called, _, _ = controller_for("crane3", "cascade")
    runs = [ml.simulate(inside.spec, controller=c, duration=0.6, initial={"q": q0, "dP": "gravity"})
            for c in (inside, PythonOnly(called))]
    assert len(inside.times) == len(called.times) == 300
    for name in ("q", "qd", "dP", "ctrl"):
        np.testing.assert_array_equal(runs[0][name], runs[1][name], err_msg=name)
    for name, values in called.signals().items():
        np.testing.assert_array_equal(inside.signals()[name], values, err_msg=name)
    np.testing.assert_array_equal(runs[0]["tau_d"], inside.signals_at(runs[0].t)["ctrl.tau_d"])


def test_a_model_without_compiled_kernels_is_refused_in_one_line() -> None:
    spec = ml.builtin_spec("planar2")
    model = ml.AnalyticModel(spec, backend="python", cache=False)
    move = Hold(Pose.from_matrix(model.fk(np.array([0.3, 1.2]))), 1.0)
    with pytest.raises(ml.control.errors.ControlError, match="C backend") as caught:
        CascadeController(spec, move, model=model)
    assert "\n" not in str(caught.value)


def test_a_pinned_cylinders_drive_reads_pA_and_pB_from_the_plants_state() -> None:
    """Called with a plant's state, the compiled cascade's pinned-cylinder drive gets pA and pB as
    the plant holds them: its command equals the Python drive's (ChamberDrive.command) for the
    same desired forces, and it is not what zero pressures would give."""
    spec = ml.builtin_spec("patu655")
    plant = ml.Plant(spec)
    plant.set_state(q=[0.2, -0.4, 1.0])
    plant.balance_pressures()
    model = ml.AnalyticModel(spec)
    controller = CascadeController(spec, Hold(Pose.from_matrix(model.fk(plant.state().q)), 1.0),
                                   model=model)
    assert not controller._python  # every drive compiled
    state = plant.state()
    cmd = controller(0.0, state)
    tau = controller.signals()["tau_d"][0]
    drive = next(d for d in controller.drives if "pA" in d.needs)
    fresh = type(drive)(drive.cylinders, drive.joints, dt=controller.dt,
                        settings=controller.gains)
    j = drive.joints
    qd_ref = np.zeros(spec.n)
    want = fresh.command(tau[j], state.q[j], state.qd[j], qd_ref[j],
                         {"pA": state["pA"][j], "pB": state["pB"][j]})
    np.testing.assert_allclose(cmd[j], want, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(controller.signals()["pL_d"][0][j], fresh.log["pL_d"], rtol=1e-12)
    assert np.all(state["pA"][j] > 1e6)


def test_the_pull_towards_the_planned_joint_path_equals_the_frozen_python_cascade() -> None:
    """A redundant arm (the erector on a position task) with the planner's joint path: the C
    sample's null-space pull equals the frozen Python cascade's, sample by sample."""
    from maniplab.control.point_to_point import plan_move

    spec = ml.builtin_spec("erector")
    model = ml.AnalyticModel(spec)
    q0 = [-0.18, 1.27, 0.0, 0.0, 0.0, 0.0]
    target = model.fk(np.array(q0) + [0.05, -0.05, 0.1, 0.05, 0.05, 0.0])[:3, 3]
    plan = plan_move(spec, target, start=q0, duration=1.0, t0=0.05, model=model)
    controller = CascadeController(spec, plan.move, model=model, task="position",
                                   joint_path=plan.joint_reference)
    states = closed_loop(controller, q0, 300)
    reference = reference_of(controller, states)
    assert_same(controller.signals(), reference.signals())
    free = CascadeController(spec, plan.move, model=model, task="position")
    free_states = closed_loop(free, q0, 300)
    assert not np.allclose(free_states[-1][1], states[-1][1])  # the pull does move the joints
