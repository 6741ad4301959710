"""The plant's parts on their own: the state layout, the actuators, the friction/limit automaton
and what a step publishes for recording."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import maniplab as ml
from maniplab.friction import FrictionMode
from maniplab.sim.actuation import Actuation
from maniplab.sim.automaton import HOLD_INERTIA, Automaton
from maniplab.sim.layout import LUGRE_SUFFIX

RK4 = int(mujoco.mjtIntegrator.mjINT_RK4)


@pytest.fixture(scope="module")
def mixed() -> ml.ManipulatorSpec:
    """The erector with a torque joint, a LuGre joint and a plugin motor among its cylinders."""
    motor = {"type": "plugins.dcmotor:GearedDCMotor", "resistance": 1.0, "inductance": 5e-3,
             "torque_constant": 0.5, "gear_ratio": 100.0}
    return ml.builtin_spec("erector").with_overrides({
        "joints.q4.actuator": {"type": "torque", "limit": 500.0},
        "joints.q5.actuator": motor,
        "joints.q6.friction.model": "lugre",
    })


# --- the state layout --------------------------------------------------------------------------
def test_layout_places_each_state_where_mujoco_keeps_it(mixed: ml.ManipulatorSpec) -> None:
    plant = ml.Plant(mixed)
    m = plant.model
    layout = plant.layout
    assert layout.names == ("dP", "Q", "current", "z")
    joints, adrs = layout["dP"]
    assert joints.tolist() == [0, 1, 2, 5]
    assert adrs.tolist() == [m.actuator(f"q{j + 1}").actadr[0] for j in joints]
    np.testing.assert_array_equal(layout["Q"][1], adrs + 1)
    assert layout["current"][0].tolist() == [4]
    assert layout["z"][1].tolist() == [m.actuator("q6" + LUGRE_SUFFIX).actadr[0]]
    act = np.arange(m.na, dtype=float)
    read = layout.read(act)
    assert read["current"][4] == m.actuator("q5").actadr[0]
    assert np.isnan(read["current"][[0, 1, 2, 3, 5]]).all()
    assert read["dP"].shape == (6,) and np.isnan(read["dP"][[3, 4]]).all()
    samples = layout.read(np.stack([act, 2 * act]))
    np.testing.assert_array_equal(samples["z"][1], 2 * read["z"])


def test_layout_without_states_is_empty() -> None:
    plant = ml.Plant("planar2")
    assert plant.layout.names == () and plant.states() == {}


# --- the actuators -----------------------------------------------------------------------------
def test_actuation_groups_native_actuators_and_integrates_the_others(
        mixed: ml.ManipulatorSpec) -> None:
    native = Actuation(mixed, native_route=True, dt=1e-3, integrator=RK4)
    assert native.integrated == [4]  # the plugin motor; the cylinders and the torque are native
    assert [len(g.joints) for g in native.groups] == [5]  # MuJoCo's motor, the engine plugin
    callbacks = Actuation(mixed, native_route=False, dt=1e-3, integrator=RK4)
    assert callbacks.integrated == list(range(6)) and not callbacks.groups
    assert native.clip([2.0, -2.0, 0.3, 900.0, -100.0, 0.0]) == [1.0, -1.0, 0.3, 500.0, -48.0, 0.0]


def test_actuation_forces_are_each_models_force(mixed: ml.ManipulatorSpec) -> None:
    plant = ml.Plant(mixed)
    rng = np.random.default_rng(3)
    q, qd = rng.normal(size=(5, 6)), rng.normal(size=(5, 6))
    act, ctrl = rng.normal(size=(5, plant.model.na)), rng.normal(size=(5, 6))
    tau = plant.actuator_forces_at(q, qd, act, ctrl)
    adr = plant.model.actuator_actadr
    area = [j.actuator.area for j in mixed.joints[:3]]
    np.testing.assert_allclose(tau[:, :3], act[:, adr[:3]] * area)  # A ΔP
    np.testing.assert_array_equal(tau[:, 3], ctrl[:, 3])  # the torque source
    np.testing.assert_allclose(tau[:, 4], 1.0 * 100.0 * 0.5 * act[:, adr[4]])  # η N K i


def test_actuation_reports_a_state_out_of_its_range(mixed: ml.ManipulatorSpec) -> None:
    callbacks = Actuation(mixed, native_route=False, dt=1e-3, integrator=RK4)
    plant = ml.Plant(mixed, route="callbacks")
    callbacks.bind(plant.model, plant.data)
    act = [0.0] * plant.model.na
    assert callbacks.finish([0.0] * 6, [0.0] * 6, act, [0.0] * 6, act) is None
    adr = int(plant.model.actuator_actadr[1])
    act[adr] = 11 * mixed.joints[1].actuator.supply_pressure
    joint, problem = callbacks.finish([0.0] * 6, [0.0] * 6, act, [0.0] * 6, act)
    assert joint == 1 and "10 times the supply pressure" in problem


# --- the friction/limit automaton --------------------------------------------------------------
def slider(**friction: float) -> tuple[mujoco.MjModel, mujoco.MjData, ml.Joint]:
    """A 10 kg block on a horizontal slider, with limits [-0.1, 0.1] and hybrid friction."""
    joint = ml.Joint(name="x", type="P", axis="x", limits=(-0.1, 0.1),
                     friction=ml.Friction(model="hybrid", **friction))
    s = mujoco.MjSpec()
    s.option.timestep = 1e-3
    s.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_LIMIT
    body = s.worldbody.add_body(name="b", mass=10.0, inertia=[1.0, 1.0, 1.0])
    body.add_joint(name="x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0])
    model = s.compile()
    return model, mujoco.MjData(model), joint


def test_a_stuck_joint_is_held_and_its_holding_force_read_back() -> None:
    model, data, joint = slider(coulomb=50.0, static=10.0)
    automaton = Automaton([joint], model, data, 1e-3, {})
    automaton.resync()  # at rest with stick/slip friction: stuck
    assert automaton.modes == [FrictionMode.STICK.value]
    data.qfrc_applied[0] = 0.0
    automaton.hold()
    assert model.dof_armature[0] == pytest.approx(HOLD_INERTIA * 10.0)
    data.xfrc_applied[1, 0] = 40.0  # a push below the break-away force Fc + Fs = 60 N
    fric = automaton.forces([0.0], [])
    mujoco.mj_forward(model, data)
    fric = automaton.settle([0.0], [], fric)
    assert automaton.modes == [FrictionMode.STICK.value]
    assert -HOLD_INERTIA * 10.0 * data.qacc[0] == pytest.approx(-40.0, rel=1e-9)  # it holds
    data.xfrc_applied[1, 0] = 70.0  # beyond the break-away force: it slips, forwards
    fric = automaton.forces([0.0], [])
    mujoco.mj_forward(model, data)
    fric = automaton.settle([0.0], [], fric)
    assert automaton.modes == [FrictionMode.SLIP.value]
    assert fric[0] == pytest.approx(-60.0)  # Coulomb + Stribeck at v = 0, against the motion


def test_the_step_end_puts_a_joint_past_its_limit_on_it() -> None:
    model, data, joint = slider()
    automaton = Automaton([joint], model, data, 1e-3, {})
    automaton.resync()
    q1, v1 = [0.1003], [0.3]
    moved, limit = automaton.finish([0.0998], [0.3], q1, v1, [0.0])
    assert moved and (q1, v1) == ([0.1], [0.0])
    assert automaton.modes == [FrictionMode.AT_UPPER.value] and limit is None


def test_the_step_end_sticks_a_slipping_joint_that_reverses() -> None:
    model, data, joint = slider(coulomb=5.0, stick_velocity=1e-3)
    automaton = Automaton([joint], model, data, 1e-3, {})
    data.qvel[0] = 0.01
    automaton.resync()
    assert automaton.modes == [FrictionMode.SLIP.value]
    v1 = [-0.002]
    moved, _ = automaton.finish([0.0], [0.01], [0.0], v1, [0.0])
    assert moved and v1 == [0.0] and automaton.modes == [FrictionMode.STICK.value]


# --- what a step publishes ---------------------------------------------------------------------
def test_the_record_is_what_the_run_stores() -> None:
    inputs = [0.3, -0.2, 0.1, 0.4, 0.0, 0.2]
    run = ml.simulate("erector", inputs=dict(zip(("q1", "q2", "q3", "q4", "q5", "q6"), inputs)),
                      duration=0.05, sample_dt=1e-3)
    plant = ml.Plant("erector")
    with plant.scope():
        for k in range(50):
            plant.prepare(list(inputs))
            record = plant.record
            assert record.t == pytest.approx(run.t[k], abs=1e-12)
            np.testing.assert_array_equal(record.q, run.q[k])
            np.testing.assert_array_equal(record.u, run["ctrl"][k])
            np.testing.assert_array_equal(record.mode, run["mode"][k])
            plant.advance()
            np.testing.assert_allclose(np.array(plant.record.fric) - plant.viscous * run.qd[k],
                                       run["tau_fric"][k], rtol=0, atol=1e-9)
