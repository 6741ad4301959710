"""Actuator plugins: a DC motor defined outside maniplab (tests/plugins/dcmotor.py), named in a
spec and simulated with no change to maniplab; spec validation of its parameters; the registry;
and MuJoCo's process-global callbacks, which plugin actuators use, handled safely."""

from __future__ import annotations

import importlib.metadata
import math
import sys
import textwrap
import threading

import mujoco
import numpy as np
import pytest
from plugins.dcmotor import GearedDCMotor
from scipy.integrate import solve_ivp

import maniplab as ml
from maniplab.actuators import registry as registry_module

MOTOR = {"resistance": 1.0, "inductance": 5e-3, "torque_constant": 0.05, "gear_ratio": 20.0,
         "efficiency": 0.9, "voltage_limit": 24.0}
MASS, LENGTH, DAMPING = 2.0, 0.5, 0.02


def motor_arm(actuator_type: str = "plugins.dcmotor:GearedDCMotor",
              **params: float) -> ml.ManipulatorSpec:
    """One rotational joint about the vertical axis (no gravity torque), a 2 kg, 0.5 m rod."""
    return ml.ManipulatorSpec.from_dict({
        "name": "motor-arm",
        "joints": [{
            "name": "j", "type": "R", "axis": "z",
            "body": {"length": LENGTH, "mass": MASS},
            "actuator": {"type": actuator_type, **MOTOR, **params},
            "friction": {"model": "hybrid", "viscous": DAMPING},
        }],
    })


def motor_reference(t: np.ndarray, voltage: float) -> np.ndarray:
    """Radau solution of the motor and rod: rows θ, ω, i at times t."""
    J = MASS * LENGTH**2 / 3.0  # slender rod about its end
    R, L, K, N, eta = (MOTOR[k] for k in ("resistance", "inductance", "torque_constant",
                                          "gear_ratio", "efficiency"))

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        _theta, omega, i = y
        return [omega, (eta * N * K * i - DAMPING * omega) / J,
                (voltage - R * i - K * N * omega) / L]

    sol = solve_ivp(rhs, (t[0], t[-1]), [0.0, 0.0, 0.0], method="Radau", rtol=1e-11, atol=1e-13,
                    t_eval=t)
    return sol.y


def test_dc_motor_plugin_matches_an_independent_integration() -> None:
    run = ml.simulate(motor_arm(), inputs={"j": ml.signals.step(12.0)}, duration=0.4,
                      sample_dt=1e-3)
    theta, omega, current = motor_reference(run.t, 12.0)
    assert np.max(np.abs(run["current"][:, 0] - current)) < 1e-4 * np.max(np.abs(current))
    assert np.max(np.abs(run.qd[:, 0] - omega)) < 1e-4 * np.max(np.abs(omega))
    assert np.max(np.abs(run.q[:, 0] - theta)) < 1e-4 * np.max(np.abs(theta))
    # the recorded force is the plugin's: η N K i
    np.testing.assert_allclose(run["tau_act"][:, 0], 0.9 * 20 * 0.05 * run["current"][:, 0])


def test_plugin_command_is_clipped_to_its_limit() -> None:
    run = ml.simulate(motor_arm(), inputs={"j": 100.0}, duration=0.01)
    assert np.all(run["ctrl"][:, 0] == 24.0)
    assert np.all(np.isnan(run["iv"]))  # no valve on this joint


def test_plugin_spec_round_trips_and_reloads_from_a_run_file(tmp_path) -> None:
    spec = motor_arm()
    assert spec.joints[0].actuator.params.gear_ratio == 20.0
    data = spec.to_dict()
    assert data["joints"][0]["actuator"] == {"type": "plugins.dcmotor:GearedDCMotor", **MOTOR}
    assert ml.ManipulatorSpec.from_dict(data) == spec
    spec.dump(tmp_path / "motor.yaml")
    assert ml.load_spec(tmp_path / "motor.yaml") == spec
    run = ml.simulate(spec, inputs={"j": 5.0}, duration=0.02)
    run.save(tmp_path / "run.npz")
    assert ml.Run.load(tmp_path / "run.npz").spec == spec


def test_mjcf_gives_a_plugin_one_activation_per_state() -> None:
    model = ml.build_model(motor_arm())
    act = model.actuator("j")
    assert model.actuator_actnum[act.id] == 1
    assert model.actuator_dyntype[act.id] == mujoco.mjtDyn.mjDYN_USER
    assert model.actuator_biastype[act.id] == mujoco.mjtBias.mjBIAS_USER
    assert list(act.ctrlrange) == [-24.0, 24.0]
    assert "j" in ml.to_mjcf(motor_arm())


@pytest.mark.parametrize(("edit", "field", "words"), [
    ("resistance: 1.0", "actuator.resistance", ["expected a number > 0", "-2"]),
    ("inductance: 0.005", "actuator.inductanse", ["unknown key 'inductanse'",
                                                  "did you mean 'inductance'"]),
    ("gear_ratio: 20", "actuator.gear_ratio", ["expected a number", "'twenty'"]),
])
def test_bad_plugin_parameters_name_file_joint_and_field(tmp_path, edit, field, words) -> None:
    bad = {"resistance: 1.0": "resistance: -2.0", "inductance: 0.005": "inductanse: 0.005",
           "gear_ratio: 20": "gear_ratio: twenty"}[edit]
    text = textwrap.dedent("""\
        name: motor
        joints:
          - name: wrist
            type: R
            axis: z
            body: {length: 0.5, mass: 2.0}
            actuator:
              type: plugins.dcmotor:GearedDCMotor
              resistance: 1.0
              inductance: 0.005
              torque_constant: 0.05
              gear_ratio: 20
        """).replace(edit, bad)
    path = tmp_path / "motor.yaml"
    path.write_text(text)
    with pytest.raises(ml.SpecError) as caught:
        ml.load_spec(path)
    error = caught.value
    assert (error.file, error.joint, error.field) == (str(path), "wrist", field)
    assert error.line is not None and 8 <= error.line <= 12
    for word in words:
        assert word in str(error)


@pytest.mark.parametrize(("kind", "words"), [
    ("nosuchmodule.motors:Motor", ["names module 'nosuchmodule.motors', which was not loaded",
                                   "--plugin nosuchmodule.motors",
                                   "MANIPLAB_PLUGINS=nosuchmodule.motors"]),
    ("plugins.dcmotor:Nothing", ["has no 'Nothing'"]),
    ("plugins.dcmotor:DCMotorParams", ["not a subclass of maniplab.actuators.ActuatorPlugin"]),
    ("electrik", ["unknown actuator type 'electrik'", "'torque', 'hydraulic' or 'passive'",
                  "'module:Class'"]),
])
def test_unknown_plugin_types_are_spec_errors(kind, words) -> None:
    with pytest.raises(ml.SpecError) as caught:
        motor_arm(kind)
    assert caught.value.field == "actuator.type"
    for word in words:
        assert word in str(caught.value)


def test_a_module_named_on_purpose_is_imported_once_named(monkeypatch) -> None:
    """``module:Class`` resolves only after load_plugins or MANIPLAB_PLUGINS names the module
    (tests/plugins/spring.py is imported nowhere else)."""
    monkeypatch.delitem(sys.modules, "plugins.spring", raising=False)
    monkeypatch.delenv("MANIPLAB_PLUGINS", raising=False)
    monkeypatch.setattr(registry_module, "_LOADED", set())
    monkeypatch.setattr(registry_module, "_RESOLVED", {})
    with pytest.raises(ml.SpecError, match="names module 'plugins.spring', which was not loaded"):
        spring_arm()
    assert "plugins.spring" not in sys.modules
    monkeypatch.setenv("MANIPLAB_PLUGINS", "json, plugins.spring")
    spec = spring_arm()
    assert type(ml.spec.model_of(spec.joints[0])).__name__ == "LinearSpring"
    assert "plugins.spring" in sys.modules
    monkeypatch.delenv("MANIPLAB_PLUGINS")
    monkeypatch.delitem(sys.modules, "plugins.spring")
    monkeypatch.setattr(registry_module, "_LOADED", set())
    monkeypatch.setattr(registry_module, "_RESOLVED", {})
    ml.load_plugins("plugins.spring")
    assert spring_arm().joints[0].actuator.stiffness == 5.0


def spring_arm() -> ml.ManipulatorSpec:
    """One joint on the plugin of tests/plugins/spring.py."""
    return ml.ManipulatorSpec.from_dict({"joints": [{
        "type": "R", "axis": "z", "body": {"length": LENGTH, "mass": MASS},
        "actuator": {"type": "plugins.spring:LinearSpring", "stiffness": 5.0}}]})


@pytest.mark.parametrize(("module", "words"), [
    ("nosuchmodule", ["cannot import plugin module 'nosuchmodule'", "ModuleNotFoundError"]),
    ("not a module", ["'not a module' is not a module name"]),
])
def test_load_plugins_fails_in_one_line(module, words) -> None:
    with pytest.raises(ml.actuators.PluginLookupError) as caught:
        ml.load_plugins(module)
    assert "\n" not in str(caught.value)
    for word in words:
        assert word in str(caught.value)


def test_registered_names_and_entry_points(monkeypatch) -> None:
    monkeypatch.setitem(registry_module._REGISTRY, "test-motor", GearedDCMotor)
    assert isinstance(ml.spec.model_of(motor_arm("test-motor").joints[0]), GearedDCMotor)
    point = importlib.metadata.EntryPoint(name="test-dcmotor",
                                          value="plugins.dcmotor:GearedDCMotor",
                                          group=ml.actuators.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry_module, "entry_points", lambda group: [point])
    spec = motor_arm("test-dcmotor")
    assert isinstance(ml.spec.model_of(spec.joints[0]), GearedDCMotor)
    assert ml.actuators.resolve("torque") is ml.actuators.TorqueSource
    with pytest.raises(ValueError, match="already registered"):
        ml.actuators.register("torque", GearedDCMotor)
    with pytest.raises(TypeError, match="not a subclass"):
        ml.actuators.register("x", dict)  # type: ignore[arg-type]


def test_the_interface_rejects_reserved_state_names() -> None:
    with pytest.raises(TypeError, match="not a valid state name"):
        class Bad(ml.actuators.ActuatorPlugin):
            Params = dict
            states = ("q",)

            def derivatives(self, x, u, q, v):  # pragma: no cover
                return x

            def force(self, x, u, q, v):  # pragma: no cover
                return 0.0


def test_a_stateless_plugin() -> None:
    spec = motor_arm().with_overrides({"joints.j.actuator": {"type": "plugins.dcmotor:Spring",
                                                             "stiffness": 3.0}})
    run = ml.simulate(spec, inputs={"j": 0.5}, duration=0.05)
    # torque k (u - q), and no state signal for it
    np.testing.assert_allclose(run["tau_act"][:, 0], 3.0 * (0.5 - run.q[:, 0]))
    assert "current" not in run


# --- callbacks: process-global, handled per plant ---------------------------------------------

SENTINEL_CALLS: list[int] = []


def _sentinel_dyn(m, d, i):
    SENTINEL_CALLS.append(i)
    return 0.0


def _sentinel_bias(m, d, i):
    SENTINEL_CALLS.append(i)
    return 0.0


@pytest.fixture
def sentinels():
    """Callbacks that 'someone else' installed; every plant must give them back."""
    mujoco.set_mjcb_act_dyn(_sentinel_dyn)
    mujoco.set_mjcb_act_bias(_sentinel_bias)
    yield
    mujoco.set_mjcb_act_dyn(None)
    mujoco.set_mjcb_act_bias(None)


def _restored() -> bool:
    return (mujoco.get_mjcb_act_dyn() is _sentinel_dyn
            and mujoco.get_mjcb_act_bias() is _sentinel_bias)


def test_callbacks_are_restored_after_a_run(sentinels) -> None:
    """While the plant steps, its own callbacks answer its Python actuator (someone else's are
    never called), and theirs are back afterwards."""
    SENTINEL_CALLS.clear()
    run = ml.simulate(motor_arm(), inputs={"j": 6.0}, duration=0.01,
                      controller=lambda t, s: [0.0])
    assert not SENTINEL_CALLS and run["current"][-1, 0] > 0.0  # the motor was integrated
    assert _restored()


def test_two_plugin_plants_interleaved_give_the_results_of_each_alone(sentinels) -> None:
    slow, fast = motor_arm(), motor_arm(gear_ratio=10.0)
    alone = [ml.simulate(s, inputs={"j": 12.0}, duration=0.05).q for s in (slow, fast)]
    a, b = ml.Plant(slow), ml.Plant(fast)
    qa, qb = [], []
    for _ in range(50):
        a.step([12.0])
        b.step([12.0])
        qa.append(a.data.qpos[0])
        qb.append(b.data.qpos[0])
    assert qa == alone[0][1:, 0].tolist()
    assert qb == alone[1][1:, 0].tolist()
    assert _restored()


def test_a_plant_inside_another_plants_controller(sentinels) -> None:
    """The inner plant installs its callbacks and gives the outer plant's back."""
    inner = ml.Plant(motor_arm(gear_ratio=10.0))

    def controller(t, state):
        inner.step([12.0])
        return [12.0]

    outer = ml.simulate(motor_arm(), controller=controller, duration=0.05)
    assert outer.q[1:, 0].tolist() == ml.simulate(motor_arm(), inputs={"j": 12.0},
                                                  duration=0.05).q[1:, 0].tolist()
    alone = ml.simulate(motor_arm(gear_ratio=10.0), inputs={"j": 12.0}, duration=0.05)
    assert inner.data.qpos[0] == alone.q[-1, 0]
    assert _restored()


def test_an_exception_in_a_step_restores_the_callbacks(sentinels) -> None:
    spec = motor_arm("plugins.dcmotor:Faulty")
    with pytest.raises(ml.PluginError) as caught:
        ml.simulate(spec, inputs={"j": 12.0}, duration=0.5)
    message = str(caught.value)
    assert "joint j" in message and "winding burnt" in message and "t = " in message
    assert isinstance(caught.value.__cause__, ValueError)
    assert _restored()
    # and the next plant runs normally
    run = ml.simulate(motor_arm(), inputs={"j": 12.0}, duration=0.4, sample_dt=1e-3)
    assert math.isclose(run["current"][-1, 0], motor_reference(run.t, 12.0)[2, -1], rel_tol=1e-4)


def test_plants_in_two_threads_do_not_mix_their_callbacks() -> None:
    specs = [motor_arm(), motor_arm(gear_ratio=10.0)]
    alone = [ml.simulate(s, inputs={"j": 12.0}, duration=0.1).q for s in specs]
    results: dict[int, np.ndarray] = {}

    def work(k: int) -> None:
        results[k] = ml.simulate(specs[k], inputs={"j": 12.0}, duration=0.1).q

    threads = [threading.Thread(target=work, args=(k,)) for k in (0, 1)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for k in (0, 1):
        np.testing.assert_array_equal(results[k], alone[k])
    assert mujoco.get_mjcb_act_dyn() is None


def test_a_foreign_model_beside_a_plant_sees_no_callbacks() -> None:
    """Stepping some other MuJoCo model while a plant with a Python actuator exists (and has
    stepped) leaves its user actuators untouched, as if no callback were installed."""
    other = ml.build_model(motor_arm())
    data = mujoco.MjData(other)
    data.act[:] = 1.0
    plant = ml.Plant(motor_arm())
    plant.step()
    mujoco.mj_step(other, data)
    assert data.act[0] == 1.0 and data.actuator_force[0] == 0.0
