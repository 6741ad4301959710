"""Rod friction of a pinned cylinder (``actuator.cylinder.friction``): newtons on the rod, mapped
onto the joint through the cylinder's moment arm r(q) = ds/dq at each step's start pose.

r(q) is computed here independently of MuJoCo and of maniplab's geometry: the complex-step
derivative of the pin-to-pin distance |R(axis, q) c - p| from the pins in the spec (exact to
round-off). The plant's slip friction, break-away and viscous force are checked against it at
random poses of patu655's lift and tilt; the identification recovers the rod's Coulomb friction
with the valve's nominal flow and flow ratio from pressures."""

from __future__ import annotations

import ctypes
import importlib.util
import shutil
import subprocess
from pathlib import Path

import mujoco
import numpy as np
import pytest
from commandline import run_cli
from identify_data import synthetic
from test_fmu import check_against_simulate, fmpy_python  # noqa: F401 (a fixture)

import maniplab as ml
from maniplab.friction import FrictionMode
from maniplab.gui.configure import joint_table, lookup, text_of
from maniplab.identification import identify
from maniplab.identification.parameters import parse_parameters
from maniplab.model.export import c_file, cylinder_terms, python_module
from maniplab.sim.plant import Plant
from maniplab.sim.sweep import variants
from maniplab.spec.yaml_io import dump_yaml
from maniplab.summary import spec_table

S = ml.signals
LIFT, TILT = "joints.lift.actuator.cylinder", "joints.tilt.actuator.cylinder"
ROD_LIFT = {"coulomb": 2000.0, "static": 800.0, "stribeck_velocity": 0.02, "viscous": 2.0e4,
            "stick_velocity": 2e-3}
ROD_TILT = {"coulomb": 1500.0, "static": 600.0, "stribeck_velocity": 0.005, "viscous": 1.0e4}


def lever(joint: ml.Joint, q: float) -> float:
    """r(q) = ds/dq, m/rad: the complex step of the pin-to-pin distance s = |R(axis, q) c - p|
    (Rodrigues' rotation of the child pin c about the joint axis; p the parent pin)."""
    pins = joint.actuator.cylinder.pins
    p, c, k = np.array(pins.parent), np.array(pins.child), joint.axis_vector
    h = 1e-30
    z = q + 1j * h
    rotated = c * np.cos(z) + np.cross(k, c) * np.sin(z) + k * (k @ c) * (1.0 - np.cos(z))
    d = rotated - p
    return float(np.sqrt(np.sum(d * d)).imag / h)


def slip(v: float, coulomb: float, static: float, stribeck: float) -> float:
    """-(Fc + Fs exp(-(v/vs)²)) sign(v)."""
    return -(coulomb + static * np.exp(-((v / stribeck) ** 2))) * np.sign(v)


def rod_spec(**changes: object) -> ml.ManipulatorSpec:
    """patu655 with rod friction on the lift (its own pin friction kept: the two add) and on
    the tilt (its own friction none: the rod's alone)."""
    return ml.builtin_spec("patu655").with_overrides({
        f"{LIFT}.friction": ROD_LIFT, f"{TILT}.friction": ROD_TILT,
        "joints.tilt.friction.model": "none", **changes})


def random_poses(spec: ml.ManipulatorSpec, count: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo, hi = (np.array([j.limits[k] for j in spec.joints]) for k in (0, 1))
    return lo + (hi - lo) * rng.uniform(0.05, 0.95, (count, spec.n))


# --- the plant ------------------------------------------------------------------------------------
def test_slip_friction_is_the_rod_force_times_r_at_random_poses() -> None:
    """On slipping joints the friction the plant applies over a step is F(v_rod) r(q) at the
    step's start (v_rod = r q̇) plus the joint's own; the record adds the viscous rod force
    -Fv r² q̇ at the start (the joints' own viscous part is the recorder's)."""
    spec = rod_spec()
    plant = Plant(spec)
    rng = np.random.default_rng(2)
    lift, tilt = spec.joint("lift"), spec.joint("tilt")
    worst = 0.0
    for q in random_poses(spec, 12):
        qd = rng.choice([-1.0, 1.0], 3) * rng.uniform(0.03, 0.12, 3)
        plant.set_state(q=q, qd=qd)
        plant.data.qacc_warmstart[:] = 0.0  # the slip force is taken at v + a h/2: here v
        plant.prepare([0.0, 0.0, 0.0])
        assert (plant.modes == FrictionMode.SLIP).all()  # no mode change: one set of forces
        plant.advance()
        rec = plant.record
        for j, joint, own in ((1, lift, True), (2, tilt, False)):
            rod = joint.actuator.cylinder.friction
            v, r = rec.qd[j], lever(joint, rec.q[j])
            f = joint.friction
            expected = (slip(v, f.coulomb, f.static, f.stribeck_velocity) if own else 0.0) \
                + abs(r) * slip(v * abs(r), rod.coulomb, rod.static, rod.stribeck_velocity) \
                - rod.viscous * r * r * v
            worst = max(worst, abs(rec.fric[j] - expected) / abs(expected))
    assert worst < 1e-12, worst


def test_breakaway_at_rest_is_the_rods_times_r_at_random_poses() -> None:
    """At rest a joint whose own friction is none breaks away exactly when the net force on it
    exceeds (Fc + Fs)|r(q)|: held at 1 - 1e-6 of it, moving at 1 + 1e-6, either way."""
    spec = rod_spec(**{"joints.lift.friction.model": "none"})
    plant = Plant(spec)
    models = plant.actuators
    for q in random_poses(spec, 5, seed=3):
        plant.set_state(q=q, qd=np.zeros(3))
        plant.prepare([0.0, 0.0, 0.0])
        gravity = plant.data.qfrc_bias.copy()  # at rest: G(q)
        for j in (1, 2):
            joint = spec.joints[j]
            rod = joint.actuator.cylinder.friction
            breakaway = rod.breakaway * abs(lever(joint, q[j]))
            for sign in (-1.0, 1.0):
                for factor, mode in ((1.0 - 1e-6, FrictionMode.STICK),
                                     (1.0 + 1e-6, FrictionMode.SLIP)):
                    # the other cylinder holds its joint's weight exactly; this one G + the test
                    force = gravity.copy()
                    force[j] += sign * factor * breakaway
                    states = {k: models[k].holding(force[k], q[k]) for k in (1, 2)}
                    plant.set_state(q=q, qd=np.zeros(3),
                                    pA={spec.joint_names[k]: x[0] for k, x in states.items()},
                                    pB={spec.joint_names[k]: x[1] for k, x in states.items()})
                    plant.prepare([0.0, 0.0, 0.0])
                    net = plant.data.qfrc_actuator[j] - plant.data.qfrc_bias[j]
                    assert net == pytest.approx(sign * factor * breakaway, rel=1e-9)
                    assert plant.modes[j] == mode, (q, j, sign, factor)
                    assert plant.modes[3 - j] == FrictionMode.STICK


def test_a_slowing_rod_sticks_below_its_stick_velocity_over_r() -> None:
    """The tilt (Coulomb rod friction alone, its weight held by its chambers) slowing down by
    friction sticks when its mid-step speed v + a h/2 falls below the rod's stick velocity /
    |r(q)| (2 % either side), either way."""
    spec = rod_spec(**{f"{TILT}.friction": {"coulomb": 1500.0, "stick_velocity": 2e-3}})
    plant = Plant(spec)
    h, models = plant.dt, plant.actuators
    for q in random_poses(spec, 4, seed=8):
        plant.set_state(q=q, qd=np.zeros(3))
        plant.prepare([0.0, 0.0, 0.0])
        states = {k: models[k].holding(plant.data.qfrc_bias[k], q[k]) for k in (1, 2)}
        pressures = {name: {spec.joint_names[k]: x[i] for k, x in states.items()}
                     for i, name in enumerate(("pA", "pB"))}
        threshold = 2e-3 / abs(lever(spec.joint("tilt"), q[2]))
        for sign in (-1.0, 1.0):
            plant.set_state(q=q, qd=[0.0, 0.0, 2.0 * sign * threshold], **pressures)
            plant.data.qacc_warmstart[:] = 0.0
            plant.prepare([0.0, 0.0, 0.0])
            a = plant.data.qacc[2]  # Coulomb's deceleration, the same at any speed
            assert a * sign < 0.0 and plant.modes[2] == FrictionMode.SLIP
            for factor, mode in ((0.98, FrictionMode.STICK), (1.02, FrictionMode.SLIP)):
                v = sign * factor * (threshold + abs(a) * h / 2)
                plant.set_state(q=q, qd=[0.0, 0.0, v], **pressures)
                plant.data.qacc_warmstart[:] = 0.0
                plant.prepare([0.0, 0.0, 0.0])
                assert plant.modes[2] == mode, (q, sign, factor)


def test_viscous_rod_friction_is_fv_r_squared_on_the_joint() -> None:
    """The rod's viscous part is the cylinder tendon's damping: MuJoCo's damping force on the
    joint is -(b + Fv r²) q̇ (b the joint's own), and the record holds -Fv r² q̇."""
    spec = ml.builtin_spec("patu655").with_overrides({
        f"{LIFT}.friction.viscous": 3.0e4, f"{TILT}.friction.viscous": 1.2e4,
        "joints.tilt.friction.model": "none"})
    plant = Plant(spec)
    rng = np.random.default_rng(4)
    worst = 0.0
    for q in random_poses(spec, 8, seed=5):
        qd = rng.choice([-1.0, 1.0], 3) * rng.uniform(0.03, 0.12, 3)
        plant.set_state(q=q, qd=qd)
        plant.data.qacc_warmstart[:] = 0.0
        plant.prepare([0.0, 0.0, 0.0])
        damper = plant.data.qfrc_damper.copy()
        plant.advance()
        for j in (1, 2):
            joint = spec.joints[j]
            fv, r = joint.actuator.cylinder.friction.viscous, lever(joint, q[j])
            own = joint.friction.damping
            worst = max(worst, abs(damper[j] + (own + fv * r * r) * qd[j])
                        / abs((own + fv * r * r) * qd[j]))
            f = joint.friction
            pin = slip(qd[j], f.coulomb, f.static, f.stribeck_velocity) if j == 1 else 0.0
            assert plant.record.fric[j] - pin == pytest.approx(-fv * r * r * qd[j], rel=1e-9)
    assert worst < 1e-12, worst


@pytest.mark.filterwarnings("ignore::maniplab.mjcf_gen.accuracy.StepWarning")
def test_stiff_viscous_rod_friction_is_stable_with_the_implicit_integrator() -> None:
    """A rod damping whose rate Fv r²/I is beyond RK4's bound at 1 ms (RK4 grows 8 % a step)
    runs stable with MuJoCo's implicit integrator, which takes the tendon's damping implicitly:
    the lift creeps slower than G/(Fv r²) (its closed chambers take part of its weight)."""
    spec = ml.builtin_spec("patu655").with_overrides({f"{LIFT}.friction.viscous": 1.0e8})
    speeds = {}
    for integrator in ("RK4", "implicitfast"):
        plant = Plant(spec, dt=1e-3, integrator=integrator)
        plant.set_state(q=[0.0, -0.3, 1.2], qd=[0.0, 0.1, 0.0])
        for _ in range(100):
            plant.step([0.0, 0.0, 0.0])
        speeds[integrator] = plant.state().qd[1]
    assert abs(speeds["RK4"]) > 0.3
    r = lever(spec.joint("lift"), plant.state().q[1])
    creep = abs(plant.data.qfrc_bias[1]) / (1.0e8 * r * r)  # G/(Fv r²): 4e-4 rad/s
    assert abs(speeds["implicitfast"]) < creep


def test_an_arm_without_rod_friction_gets_no_rod_arrays() -> None:
    config = Plant("patu655").native_config()
    assert config["rod"] == [0, 0, 0] and config["rod_coulomb"] == [0.0, 0.0, 0.0]
    rod = Plant(rod_spec(**{"joints.lift.friction.model": "none"})).native_config()
    assert rod["rod"] == [0, 1, 1] and rod["slip"] == [1, 1, 1]
    assert rod["coulomb"][1:] == [0.0, 0.0]  # a joint of model none has no friction of its own


def test_the_exported_models_give_the_rod_friction_on_the_joint(tmp_path: Path) -> None:
    """The Python module's and the C file's rod_friction(q, qd) are -(Fc + Fs e^(-(r q̇/vs)²))
    |r| sign(q̇) - Fv r² q̇ (1e-12), 0 at joints without rod friction; LaTeX and Markdown write
    it under Cylinders."""
    spec = rod_spec()
    py, source, lib = tmp_path / "patu.py", tmp_path / "patu.c", tmp_path / "libpatu.so"
    py.write_text(python_module(spec))
    source.write_text(c_file(spec))
    subprocess.run([shutil.which("cc") or "gcc", "-O1", "-shared", "-fPIC", "-Wall", "-Werror",
                    str(source), "-o", str(lib), "-lm"], check=True)
    loader = importlib.util.spec_from_file_location("patu_model", py)
    module = importlib.util.module_from_spec(loader)
    loader.loader.exec_module(module)
    function = ctypes.CDLL(str(lib)).patu655_rod_friction
    rng = np.random.default_rng(6)
    for q in random_poses(spec, 5, seed=7):
        qd = rng.uniform(-0.1, 0.1, 3)
        want = np.zeros(3)
        for j in (1, 2):
            joint = spec.joints[j]
            rod, r = joint.actuator.cylinder.friction, lever(joint, q[j])
            want[j] = abs(r) * slip(r * qd[j], rod.coulomb, rod.static, rod.stribeck_velocity) \
                * np.sign(r) - rod.viscous * r * r * qd[j]
        np.testing.assert_allclose(module.rod_friction(q, qd), want, rtol=1e-12)
        out = np.zeros(3)
        function(*(np.ascontiguousarray(x).ctypes.data_as(ctypes.POINTER(ctypes.c_double))
                   for x in (q, qd, out)))
        np.testing.assert_allclose(out, want, rtol=1e-12)
    assert cylinder_terms(spec)[0].latex()[-1].startswith("\\tau_{f,2} = -\\left(2000.0 + 800.0")


# --- the spec --------------------------------------------------------------------------------------
def test_a_bad_rod_friction_is_one_line_naming_the_joint_and_field(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    base = ml.builtin_spec("patu655")
    with pytest.raises(ml.SpecError) as info:
        base.with_overrides({f"{LIFT}.friction.coulomb": -2000.0})
    line = str(info.value)
    assert "\n" not in line and info.value.joint == "lift"
    assert info.value.field == "actuator.cylinder.friction.coulomb" and ">= 0" in line
    data = base.to_dict()
    data["joints"][2]["actuator"]["cylinder"]["friction"] = {"coulomb": 100.0, "viscus": 1.0}
    path = tmp_path / "patu.yaml"
    path.write_text(dump_yaml(data))
    code, out, err = run_cli(capsys, "validate", str(path))
    assert code == 2, out + err
    line = err.strip()
    assert "\n" not in line and "joint tilt" in line
    assert "'actuator.cylinder.friction.viscus'" in line and "unknown key" in line


def test_lugre_with_rod_coulomb_friction_is_refused_naming_the_joint() -> None:
    base = ml.builtin_spec("patu655")
    with pytest.raises(ml.SpecError) as info:
        base.with_overrides({f"{LIFT}.friction.static": 500.0, "joints.lift.friction.model":
                             "lugre"})
    assert info.value.joint == "lift" and info.value.field == "friction"
    assert "lugre" in str(info.value) and "\n" not in str(info.value)
    # the rod's viscous part alone is MuJoCo's damping: it goes with LuGre
    base.with_overrides({f"{LIFT}.friction.viscous": 500.0, "joints.lift.friction.model": "lugre"})


def test_rod_friction_reaches_the_mjcf_info_gui_and_the_parameter_paths(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    spec = rod_spec()
    exported = mujoco.MjModel.from_xml_string(ml.to_mjcf(spec))
    tendon = mujoco.mj_name2id(exported, mujoco.mjtObj.mjOBJ_TENDON, "lift/cylinder")
    assert exported.tendon_damping[tendon] == 2.0e4
    assert exported.tendon_frictionloss[tendon] == 2000.0
    plant = Plant(spec)
    assert plant.model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS
    info = spec_table(spec)
    assert "hybrid + rod" in info and "none + rod" in info
    assert "rod friction: Coulomb 2000 N, static 800 N" in info
    joint = spec.to_dict()["joints"][1]
    assert "friction:\n  coulomb: 2000.0" in text_of(lookup(joint, "actuator.cylinder"))
    table = joint_table(spec)  # one column per joint: the rod's friction a row of its own
    assert "rod friction Fc / Fs / Fv [N, N·s/m]" in table and "<td>2000/800/2e+04</td>" in table
    # --set (one override), a sweep's variants, identify's parameters
    path = f"{LIFT}.friction.coulomb"
    code, out, err = run_cli(capsys, "simulate", "patu655", "--set", f"{path}=2000",
                             "--duration", "0.05", "-o", str(tmp_path / "run.npz"))
    assert code == 0, out + err
    assert ml.Run.load(tmp_path / "run.npz").spec.joint("lift").rod_friction.coulomb == 2000.0
    grid = variants({path: [1000.0, 3000.0]})
    assert [ml.builtin_spec("patu655").with_overrides(v).joint("lift").rod_friction.coulomb
            for v in grid] == [1000.0, 3000.0]
    (parameter,) = parse_parameters([path], spec)
    assert (parameter.start, parameter.lower) == (2000.0, 0.0)


def test_the_fmu_carries_rod_friction(fmpy_python, tmp_path) -> None:  # noqa: F811
    """The FMU's config has the rod friction's arrays: it matches ``ml.simulate`` to 1e-6."""
    run = check_against_simulate(rod_spec(), 1.0, fmpy_python, tmp_path)
    assert (run["mode"][:, 1:] == FrictionMode.STICK).any()  # the rods stuck: a real test


# --- identification ------------------------------------------------------------------------------
def test_rod_coulomb_and_the_valve_are_recovered_from_pressures_five_times_off() -> None:
    """patu655's lift: the rod's Coulomb friction, the valve's nominal flow and its B/A flow
    ratio, fitted from the lift's position and chamber pressures (noise 0.1 mm, 0.2 bar), from a
    start five times off each."""
    spec = rod_spec()
    coulomb = f"{LIFT}.friction.coulomb"
    flow, ratio = "joints.lift.actuator.valve.nominal_flow", "joints.lift.actuator.valve.flow_ratio"
    truth = {coulomb: 2000.0, flow: 6.0e-4, ratio: 0.6}
    lift = {"lift": S.step(0.4, 0.1) + S.step(-0.8, 0.4) + S.step(0.4, 0.7)}
    data = synthetic(spec, truth, lift, [0.0, -0.3, 1.2], 1.0, rate=0.004,
                     noise={"q": 1e-4, "pA": 2e4, "pB": 2e4})
    start = spec.with_overrides({coulomb: 5.0 * truth[coulomb], flow: 5.0 * truth[flow],
                                 ratio: truth[ratio] / 5.0})
    result = identify(start, [data], list(truth), progress=False)
    # measured: Coulomb -0.39 %, nominal flow -0.002 %, flow ratio -0.05 %, each 95 % interval
    # holding the truth (not asserted: the rod sticks a step early or late, and the Coulomb's
    # interval, ±0.7 %, can miss it by a hair with other noise)
    for p, value in zip(result.parameters, result.values):
        assert value == pytest.approx(truth[p.path], rel=0.05), p.path
