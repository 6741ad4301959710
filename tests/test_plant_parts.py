"""The plant's parts on their own: the state layout, the actuators, the friction/limit automaton
(in C, through the plant) and what a step publishes for recording."""

from __future__ import annotations

import numpy as np
import pytest

import maniplab as ml
from maniplab.friction import FrictionMode
from maniplab.mjcf_gen.names import LUGRE_SUFFIX
from maniplab.sim.actuation import Actuation
from maniplab.sim.plant import HOLD_INERTIA


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
def test_actuation_finds_the_python_actuators(mixed: ml.ManipulatorSpec) -> None:
    actuation = Actuation(mixed)
    actuation.bind(ml.Plant(mixed).model)
    assert actuation.integrated == [4]  # the plugin motor; cylinders and torque are MuJoCo's
    assert actuation.clip([2.0, -2.0, 0.3, 900.0, -100.0, 0.0]) == [1.0, -1.0, 0.3, 500.0, -48.0,
                                                                    0.0]


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


def test_a_state_out_of_its_range_stops_the_plant(mixed: ml.ManipulatorSpec) -> None:
    plant = ml.Plant(mixed)
    plant.step()
    supply = mixed.joints[1].actuator.supply_pressure
    plant.set_state(dP={"q2": 11 * supply})
    with pytest.raises(ml.InstabilityError, match="joint q2.*10 times the supply pressure"):
        plant.step()


# --- the friction/limit automaton --------------------------------------------------------------
def slider(**friction: float) -> ml.Plant:
    """A 10 kg block on a horizontal slider, with limits [-0.1, 0.1], hybrid friction and a force
    source."""
    joint = {"name": "x", "type": "P", "axis": "x", "limits": [-0.1, 0.1], "body": {"mass": 10.0},
             "actuator": {"type": "torque"}, "friction": {"model": "hybrid", **friction}}
    return ml.Plant(ml.ManipulatorSpec.from_dict({"name": "slider", "joints": [joint]}))


def test_a_stuck_joint_is_held_and_its_holding_force_read_back() -> None:
    plant = slider(coulomb=50.0, static=10.0)
    assert plant.modes.tolist() == [FrictionMode.STICK]  # at rest with stick/slip friction
    assert plant.hold_inertia == pytest.approx(HOLD_INERTIA * 10.0)
    plant.step([40.0])  # a push below the break-away force Fc + Fs = 60 N
    assert plant.modes.tolist() == [FrictionMode.STICK] and plant.data.qpos[0] == 0.0
    assert plant.tau_fric[0] == pytest.approx(-40.0, rel=1e-9)  # it holds, exactly
    plant.step([70.0])  # beyond the break-away force: it slips, forwards
    assert plant.modes.tolist() == [FrictionMode.SLIP] and plant.data.qvel[0] > 0.0
    assert plant.tau_fric[0] == pytest.approx(-60.0)  # Coulomb + Stribeck at v = 0


def test_a_joint_past_its_limit_is_put_on_it() -> None:
    plant = slider()
    plant.set_state(q=[0.0998], qd=[0.3])
    plant.step([0.0])
    assert plant.data.qpos[0] == 0.1 and plant.data.qvel[0] == 0.0
    assert plant.modes.tolist() == [FrictionMode.AT_UPPER]
    plant.step([50.0])  # pushed on into the stop: held there by its force
    assert plant.data.qpos[0] == 0.1 and plant.tau_limit[0] == pytest.approx(-50.0, rel=1e-9)
    plant.step([-50.0])  # pulled back: released
    assert plant.modes.tolist() == [FrictionMode.SLIP] and plant.data.qpos[0] < 0.1


def test_a_slipping_joint_that_reverses_sticks() -> None:
    plant = slider(coulomb=5.0, stick_velocity=1e-3)
    plant.set_state(qd=[0.01])
    assert plant.modes.tolist() == [FrictionMode.SLIP]
    for _ in range(100):  # Coulomb friction alone brings it to rest within 20 ms
        plant.step([0.0])
    assert plant.modes.tolist() == [FrictionMode.STICK] and plant.data.qvel[0] == 0.0
    assert 0.0 < plant.data.qpos[0] <= 0.01**2 / (2 * 5.0 / 10.0) * (1 + 1e-2)


# --- what a step publishes ---------------------------------------------------------------------
def test_the_record_is_what_the_run_stores() -> None:
    inputs = [0.3, -0.2, 0.1, 0.4, 0.0, 0.2]
    run = ml.simulate("erector", inputs=dict(zip(("q1", "q2", "q3", "q4", "q5", "q6"), inputs)),
                      duration=0.05, sample_dt=1e-3)
    plant = ml.Plant("erector")
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
