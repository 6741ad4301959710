"""The FMU export: built by maniplab, run by FMPy in a virtual environment without maniplab.

Reference: ``ml.simulate`` on the same arm with the same step and inputs (the same engine: the
FMU holds maniplab's plant in C and MuJoCo's library). The FMU's outputs after a step are the
state at the step's end; ``ml.simulate``'s record of that time is the state at the next step's
start, after the automaton's decisions there (a joint found to stop within that step gets q̇ = 0,
a stuck one may break away). So positions and actuator states agree to 1e-6 everywhere; a
velocity and a mode may differ only at a sample where ``ml.simulate`` records the joint at rest.
"""

from __future__ import annotations

import fcntl
import json
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest

import maniplab as ml
from maniplab.fmu import FmuError, build_fmu
from maniplab.fmu.build import _plugin_values
from maniplab.fmu.template import fill, model_template
from maniplab.mjcf_gen.accuracy import StepWarning
from maniplab.sim.plant import Plant
from maniplab.sim.plant_model import build_plant_model

ROOT = Path(__file__).resolve().parents[1]
RUNNER = Path(__file__).with_name("fmu_runner.py")
ARMS = sorted((ROOT / "tests" / "arms").glob("*.yaml"))
MIXED = sorted((ROOT / "tests" / "arms" / "mixed").glob("*.yaml"))
TOL = 1e-6


@pytest.fixture(scope="session")
def fmpy_python(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The Python of ``.venv-fmpy`` (made by ``make test``; made here when missing), which has
    FMPy and neither maniplab nor mujoco."""
    python = ROOT / ".venv-fmpy" / "bin" / "python"
    with open(Path("/tmp") / "maniplab-fmpy-venv.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # xdist workers: one makes it, the others wait
        has_fmpy = python.exists() and subprocess.run(
            [str(python), "-c", "import fmpy"], capture_output=True, check=False).returncode == 0
        if not has_fmpy:
            subprocess.run([sys.executable, "-m", "venv", "--clear", str(python.parents[1])],
                           check=True)
            subprocess.run([str(python), "-m", "pip", "install", "--quiet", "fmpy>=0.3.20"],
                           check=True)
    return python


def run_fmpy(python: Path, jobs: list[dict[str, Any]], folder: Path) -> str:
    """Run the jobs in the FMPy venv; its stdout (per job OK or FAILED, and the FMU's log)."""
    path = folder / "jobs.json"
    path.write_text(json.dumps(jobs))
    done = subprocess.run([str(python), str(RUNNER), str(path)], capture_output=True, text=True,
                          timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    return done.stdout


def job(fmu: Path, out: Path, run: ml.Run, inputs: dict[str, Any], **extra: Any) -> dict:
    """A runner job replaying ``run``'s inputs (values at its sample times)."""
    names = run.spec.joint_names
    outputs = [f"{s}.{j}" for s in ("q", "qd", "mode") for j in names]
    outputs += [f"{s}.{names[j]}" for s in ("dP", "Q", "pA", "pB", "z") if s in run.signals
                for j in np.flatnonzero(~np.isnan(run[s][0]))]
    values = {f"u.{k}": [float(f(t)) for t in run.t] for k, f in inputs.items()}
    return {"fmu": str(fmu), "out": str(out), "dt": run.meta["dt"], "stop": float(run.t[-1]),
            "t": run.t.tolist(), "inputs": values, "outputs": outputs, **extra}


def assert_matches(run: ml.Run, result: Any) -> None:
    """The FMU's outputs equal ``run``'s record (module docstring)."""
    assert np.allclose(result["time"], run.t, rtol=0, atol=1e-9)
    names = run.spec.joint_names
    for j, name in enumerate(names):
        q, qd, mode = run["q"][:, j], run["qd"][:, j], run["mode"][:, j]
        assert np.max(np.abs(result[f"q.{name}"] - q)) <= TOL, name
        rest = qd == 0.0
        assert np.max(np.abs(result[f"qd.{name}"] - qd)[~rest], initial=0.0) <= TOL, name
        jump = np.max(np.abs(np.diff(qd)), initial=0.0)
        assert np.max(np.abs(result[f"qd.{name}"][rest]), initial=0.0) <= jump + TOL, name
        differ = result[f"mode.{name}"] != mode
        assert np.all(rest[differ]), f"{name}: modes differ while the joint moves"
        assert np.mean(differ) < 0.05, name
        for state in ("dP", "Q", "pA", "pB", "z"):
            key = f"{state}.{name}"
            if key in result.files:
                scale = max(1.0, float(np.max(np.abs(run[state][:, j]))))
                assert np.max(np.abs(result[key] - run[state][:, j])) <= TOL * scale, key


def steps_and_sines(spec: ml.ManipulatorSpec) -> dict[str, Any]:
    """A step (at a time between samples) on every other joint and sines on the rest, at 40 %
    of each command limit (1 where there is none)."""
    plant = Plant(spec)
    inputs: dict[str, Any] = {}
    for j, name in enumerate(spec.joint_names):
        a = 0.4 * (plant.command_limit[j] if np.isfinite(plant.command_limit[j]) else 1.0)
        if j % 2:
            inputs[name] = lambda t, a=a: a if t > 0.2005 else 0.0
        else:
            inputs[name] = lambda t, a=a, f=0.7 + 0.3 * j: a * np.sin(2 * np.pi * f * t)
    return inputs


def check_against_simulate(arm: str | Path, duration: float, python: Path,
                           folder: Path) -> ml.Run:
    """Build the arm's FMU, run it in FMPy under :func:`steps_and_sines` and assert that FMPy's
    validation passes and its outputs match ``ml.simulate``'s run, which is returned."""
    spec = ml.resolve_spec(arm)
    fmu = build_fmu(spec, folder / "arm.fmu", progress=False)
    inputs = steps_and_sines(spec)
    run = ml.simulate(spec, inputs=inputs, duration=duration, sample_dt=Plant(spec).dt,
                      progress=False)
    log = run_fmpy(python, [job(fmu, folder / "out.npz", run, inputs)], folder)
    assert "validation: []" in log and f"OK {fmu}" in log, log
    assert_matches(run, np.load(folder / "out.npz"))
    return run


# --- the two arms of the issue, 5 s ----------------------------------------------------------------
@pytest.mark.parametrize("arm", ["erector", "crane3"])
def test_fmu_matches_simulate_over_five_seconds(arm, fmpy_python, tmp_path) -> None:
    run = check_against_simulate(arm, 5.0, fmpy_python, tmp_path)
    moved = np.ptp(run["q"], axis=0)
    assert np.all(moved[1::2] > 1e-3), moved  # the steps moved their joints: a real comparison


def test_parameters_match_simulate_with_overrides(fmpy_python, tmp_path) -> None:
    """MuJoCo's step inside the FMU is fixed when it is built (the spec's values decide it): at
    this step the overridden arm needs no other, so the runs must agree to 1e-6."""
    spec = ml.resolve_spec("crane3")
    fmu = build_fmu(spec, tmp_path / "crane3.fmu", step=1e-3, progress=False)
    start = {"payload": 300.0, "leakage.luff": 3e-11, "viscous.slew": 400.0,
             "supply_pressure.telescope": 1.2e7, "q0.luff": -0.5, "q0.telescope": 5.0}
    overrides = {"end_effector.mass": 300.0, "joints.luff.actuator.leakage": 3e-11,
                 "joints.slew.friction.viscous": 400.0,
                 "joints.telescope.actuator.supply_pressure": 1.2e7}
    inputs = steps_and_sines(spec)
    assert Plant(spec.with_overrides(overrides), dt=1e-3).substeps == Plant(spec).substeps
    run = ml.simulate(spec, inputs=inputs, duration=2.0, dt=1e-3, overrides=overrides,
                      initial={"q": {"luff": -0.5, "telescope": 5.0}}, progress=False)
    default = ml.simulate(spec, inputs=inputs, duration=2.0, dt=1e-3, progress=False)
    log = run_fmpy(fmpy_python, [job(fmu, tmp_path / "out.npz", run, inputs, start=start)],
                   tmp_path)
    assert f"OK {fmu}" in log, log
    result = np.load(tmp_path / "out.npz")
    assert_matches(run, result)
    assert result["q.telescope"][0] == 2.0  # q0 beyond the stroke is put on its limit
    assert np.max(np.abs(run["q"] - default["q"])) > 0.1  # the parameters changed the run


def test_bad_parameters_steps_and_inputs_fail_in_one_line(fmpy_python, tmp_path) -> None:
    with pytest.warns(StepWarning):  # crane3 needs 0.5 ms for 1e-3; 1 ms shows the check
        fmu = build_fmu("crane3", tmp_path / "crane3.fmu", progress=False, step=1e-3)
    base = {"fmu": str(fmu), "stop": 0.01, "t": [0.0, 0.01], "outputs": ["q.luff"]}
    jobs = [
        base | {"out": str(tmp_path / "a.npz"), "dt": 1e-3, "start": {"leakage.luff": -1.0}},
        base | {"out": str(tmp_path / "b.npz"), "dt": 1.5e-3},
        base | {"out": str(tmp_path / "c.npz"), "dt": 1e-3,
                "inputs": {"u.luff": [float("nan")] * 2}},
    ]
    log = run_fmpy(fmpy_python, jobs, tmp_path)
    assert log.count("FAILED") == 3, log
    assert "parameter leakage.luff = -1: it must be zero or positive" in log
    assert "the communication step 0.0015 s is not a whole number of the FMU's steps of " \
           "0.001 s" in log
    assert "joint luff: input u.luff = nan is not a finite number" in log


# --- every other arm: built, validated and matching a 1 s run ----------------------------------
@pytest.mark.parametrize("arm", ["erector_pinned", "excavator", "patu655", "planar2", *ARMS],
                         ids=lambda a: Path(a).stem)
def test_fmu_of_every_arm_matches_simulate(arm, fmpy_python, tmp_path) -> None:
    check_against_simulate(arm, 1.0, fmpy_python, tmp_path)


# --- arms that mix lumped and pinned cylinders (issue 33) ---------------------------------------
@pytest.mark.parametrize("arm", MIXED, ids=lambda a: Path(a).stem)
def test_fmu_of_mixed_arm_matches_simulate(arm, fmpy_python, tmp_path) -> None:
    """An arm whose engine plugins alternate (slew lumped, boom pinned, rotator lumped) builds
    and matches ``ml.simulate`` to 1e-6 over 1 s.

    Before: ``build_fmu`` refused it ("the FMU's model text compiles to a different
    actuator_plugin than the plant's model"): the MJCF writer grouped the plugin instances by
    plugin, so the file numbered them slew, rotator, boom where the plant has slew, boom,
    rotator."""
    check_against_simulate(arm, 1.0, fmpy_python, tmp_path)


@pytest.mark.parametrize("arm", MIXED, ids=lambda a: Path(a).stem)
def test_exported_mjcf_numbers_plugins_as_the_plant(arm) -> None:
    """The exported MJCF compiles to the plant's plugin numbering (without FMPy). Before: the
    instances came out grouped by plugin (actuator_plugin [0, 2, 1] against [0, 1, 2])."""
    plant = Plant(arm)
    model = mujoco.MjModel.from_xml_string(ml.to_mjcf(plant.spec))
    assert np.array_equal(model.actuator_plugin, plant.model.actuator_plugin)
    assert np.array_equal(model.plugin, plant.model.plugin)
    assert np.array_equal(model.plugin_stateadr, plant.model.plugin_stateadr)


# --- without FMPy ------------------------------------------------------------------------------
_DYNAMICS = ("body_mass", "body_inertia", "body_ipos", "body_pos", "body_quat", "dof_damping",
             "actuator_gainprm", "actuator_biasprm", "actuator_ctrlrange")


@pytest.mark.parametrize("arm", [*ml.builtin_specs(), *ARMS, *MIXED], ids=lambda a: Path(a).stem)
def test_template_with_other_values_compiles_to_the_overridden_plant(arm) -> None:
    """Each token sits where the spec's value goes: the template filled with new values is the
    plant model of the spec with those overrides. With a shared pump (``supply:``) the pinned
    cylinders' supply pressure is one parameter, ``supply_pressure`` (before, issue 33: one per
    cylinder, ``supply_pressure.<joint>``, whose override the spec refused as differing from the
    pump's setting)."""
    plant = Plant(arm)
    template, params = model_template(plant)
    rng = np.random.default_rng(3)
    values = {p.name: (p.default or 1.0) * rng.uniform(1.5, 3.0) for p in params}
    overridden = plant.spec.with_overrides({path: v for p in params
                                            for path, v in p.overrides(values[p.name]).items()})
    expected = build_plant_model(overridden, dt=plant.dt / plant.substeps,
                                 integrator=plant.integrator)
    model = mujoco.MjModel.from_xml_string(fill(template, values))
    for field in _DYNAMICS:
        assert np.array_equal(getattr(model, field), getattr(expected, field)), field
    assert _plugin_values(model) == _plugin_values(expected)  # leakage, supply pressures
    assert {p.name.split(".")[0] for p in params} <= {"payload", "viscous", "leakage",
                                                       "supply_pressure"}


def test_model_description_has_units_and_descriptions(tmp_path) -> None:
    fmu = build_fmu("erector_pinned", tmp_path / "e.fmu", step=2e-3, progress=False)
    with zipfile.ZipFile(fmu) as z:
        names = set(z.namelist())
        root = ET.fromstring(z.read("modelDescription.xml"))
    assert {"binaries/linux64/erector_pinned.so", "resources/model.xml"} <= names
    assert any(n.startswith("binaries/linux64/libmujoco.so") for n in names)
    units = {u.get("name") for u in root.iter("Unit")}
    variables = {v.get("name"): v for v in root.iter("ScalarVariable")}
    assert root.find("DefaultExperiment").get("stepSize") == "0.002"
    for name, unit in (("u.q1", "A"), ("q.q4", "m"), ("qd.q1", "rad/s"), ("pA.q3", "Pa"),
                       ("dP.q1", "Pa"), ("payload", "kg"), ("leakage.q3", "m3/(s.Pa)"),
                       ("viscous.q4", "N.s/m"), ("supply_pressure.q5", "Pa")):
        real = variables[name].find("Real")
        assert real.get("unit") == unit and unit in units, name
        assert variables[name].get("description"), name
    assert variables["mode.q2"].find("Integer") is not None


def test_an_actuator_written_in_python_is_refused_in_one_line(tmp_path) -> None:
    ml.load_plugins("plugins.spring")
    spec = ml.ManipulatorSpec.from_dict({"name": "springy", "joints": [{
        "name": "j1", "type": "R", "axis": "z", "body": {"length": 1.0, "mass": 2.0},
        "actuator": {"type": "plugins.spring:LinearSpring", "stiffness": 5.0}}]})
    with pytest.raises(FmuError, match="joint j1: its actuator .* is written in Python"):
        build_fmu(spec, tmp_path / "s.fmu", progress=False)
    assert not (tmp_path / "s.fmu").exists()


def test_cli_writes_the_fmu_and_refuses_a_bad_step(tmp_path) -> None:
    out = tmp_path / "crane.fmu"
    done = subprocess.run([sys.executable, "-m", "maniplab", "fmu", "crane3", "-o", str(out),
                           "--step", "0.004"], capture_output=True, text=True, check=False)
    assert done.returncode == 0 and "FMI 2.0 co-simulation" in done.stdout, done.stderr
    with zipfile.ZipFile(out) as z:
        assert b'stepSize="0.004"' in z.read("modelDescription.xml")
    bad = subprocess.run([sys.executable, "-m", "maniplab", "fmu", "crane3", "-o",
                          str(tmp_path / "x.fmu"), "--step", "-1"], capture_output=True,
                         text=True, check=False)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    assert "--step: must be a positive number of seconds" in bad.stderr
