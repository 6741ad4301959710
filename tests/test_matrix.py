"""The command × arm matrix (issue 33): every command on every built-in arm and every corpus arm.

Each cell runs one command the way a user does (``maniplab ...`` in this process, or the GUI's
3D arm without a browser) on one arm, and either succeeds and is checked against a reference
independent of the code under test where one exists, or refuses in one line (exit status 2 or 3,
its last line on stderr) with a reason that :data:`EXPECTED` lists for that arm and command. A
cell that fails otherwise, or succeeds where :data:`EXPECTED` says it refuses, fails its test.

References: plain MuJoCo loading the exported MJCF (masses, inertias and ranges as
``ml.build_model``, the end-effector where the analytic model puts it), Pinocchio on the URDF
(M and G as the analytic model), MuJoCo's M and bias for the exported Python and C models, FMPy
running the FMU (``ml.simulate``'s run to 1e-6, as ``tests/test_fmu.py``), the truth of a
synthetic experiment for ``identify``, the analytic model's forward kinematics for the end of a
closed-loop move, MuJoCo's geom poses for the GUI's 3D arm.

``python tests/test_matrix.py`` runs every cell and prints the table (``--write`` puts it into
docs/about/development.md, section "The command × arm matrix"); the test
:func:`test_the_documented_table_is_the_expected_one` keeps that section equal to this file's
:data:`EXPECTED`.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import ctypes
import fcntl
import functools
import importlib.util
import io
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np
import pytest
import yaml

import maniplab as ml
from maniplab.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"
DOC = ROOT / "docs" / "about" / "development.md"
SECTION = "## The command × arm matrix"

sys.path.insert(0, str(TESTS))  # test_fmu's helpers, also when run as a script
from identify_data import NOISE
from test_fmu import assert_matches, job, run_fmpy, steps_and_sines


def _arms() -> dict[str, str]:
    """Arm id -> spec source: the built-ins by name, the corpus by file."""
    arms = {name: name for name in ml.builtin_specs()}
    for path in sorted((TESTS / "arms").glob("*.yaml")) + sorted(
            (TESTS / "arms" / "mixed").glob("*.yaml")):
        arms[str(path.relative_to(TESTS).with_suffix(""))] = str(path)
    return arms


ARMS = _arms()

COMMANDS = ("validate", "info", "export-mjcf", "export-urdf", "model-python", "model-c", "fmu",
            "simulate", "energy", "sweep", "crossval", "tune", "control", "control-pid",
            "loadchart", "render", "identify", "gui-arm3d", "replay-html", "optimize")


FULL = os.environ.get("MANIPLAB_MATRIX") == "full"
"""The full matrix (``MANIPLAB_MATRIX=full``, and ``python tests/test_matrix.py``): every cell.
By default the slowest cells run on a few arms only, one of each kind, to keep the file to a
minute or two on two cores: FMPy runs the FMU of :data:`FMPY_ARMS` (the other arms' ``fmu``
cells still build and check theirs, and tests/test_fmu.py runs every built-in and corpus FMU in
FMPy), and ``control``, ``control-pid`` and ``identify`` run on the arms of :data:`QUICK`."""

FMPY_ARMS = ("arms/electrohydraulic", "arms/drill_boom")
_CONTROL_ARMS = ("crane3", "planar2", "erector", "arms/drill_boom", "arms/electric2",
                 "arms/electrohydraulic", "arms/pipe_handler", "arms/mixed/forestry_rotator",
                 "arms/grapple_crane")
QUICK = {"control": _CONTROL_ARMS, "control-pid": (*_CONTROL_ARMS, "arms/excavator"),
         "identify": ("planar2", "arms/electrohydraulic")}


class Expected(NamedTuple):
    """A cell that does not succeed: ``kind`` "refused" (the arm or the method cannot do it, said
    in one line) or "defect" (a known defect of maniplab, open), a substring of its one line, and
    why (for the table)."""

    kind: str
    reason: str
    why: str


_STRAIGHT = Expected("refused", "the straight path leaves the workspace",
                     "slew and boom place the tip, the rotator turns about the tip's own axis: "
                     "two joints for three coordinates, no straight Cartesian path")
_HOLD = Expected("refused", "joint shoulder cannot hold the arm on this path",
                 "at the mid-range pose (arm horizontal) the shoulder needs 83 % of its 120 N·m "
                 "to hold the arm, beyond the 80 % a move may plan with")

_NO_PINNED = Expected("refused", "has no pinned cylinder",
                     "no pinned cylinder: only pinned cylinders' energy is accounted")


def _has_pinned(arm: str) -> bool:
    return any(getattr(j.actuator, "cylinder", None) for j in ml.resolve_spec(ARMS[arm]).joints)


EXPECTED: dict[tuple[str, str], Expected] = {
    **{(arm, "energy"): _NO_PINNED for arm in ARMS if not _has_pinned(arm)},
    ("arms/electric2", "control"): _HOLD,
    ("arms/electric2", "control-pid"): _HOLD,
    ("arms/mixed/forestry_grapple", "control"): _STRAIGHT,
    ("arms/mixed/forestry_grapple", "control-pid"): _STRAIGHT,
    ("arms/grapple_crane", "control-pid"): Expected(
        "refused", "the move missed its tolerances",
        "the PID-only baseline's joint loops do not damp the hanging grapple's sway, which keeps "
        "pulling the slew: 14 mm off after 15 time constants (the cascade meets 2 mm)"),
    ("arms/mixed/forestry_rotator", "control"): _STRAIGHT,
    ("arms/mixed/forestry_rotator", "control-pid"): _STRAIGHT,
}


# --- running a command ----------------------------------------------------------------------------


class Refused(Exception):
    """A command that exited 2 or 3; its one line (the last on stderr)."""

    def __init__(self, code: int, line: str) -> None:
        super().__init__(f"exit {code}: {line}")
        self.code, self.line = code, line


def cli(*argv: str) -> str:
    """``maniplab argv`` in this process (as tests/commandline.py's run_cli, without pytest's
    capsys, so that the script can run it too): its stdout, or :class:`Refused`."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli_main(list(argv))
        except SystemExit as exc:
            code = int(exc.code or 0)
    lines = [line for line in err.getvalue().splitlines() if line.strip()]
    if code in (2, 3):
        assert lines, f"maniplab {argv[0]} exited {code} with nothing on stderr"
        raise Refused(code, lines[-1])
    assert code == 0, f"maniplab {' '.join(argv)} exited {code}: {err.getvalue()}"
    return out.getvalue()


@functools.cache
def _cache() -> Path:
    """A folder for what the cells of one process share (a run per arm)."""
    folder = Path(tempfile.mkdtemp(prefix="maniplab-matrix-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


# --- the arm's poses and inputs -------------------------------------------------------------------


@functools.cache
def spec_of(arm: str) -> ml.ManipulatorSpec:
    return ml.resolve_spec(ARMS[arm])


def raw_joints(arm: str) -> list[dict[str, Any]]:
    """The joints as the YAML file lists them (read with PyYAML, not maniplab)."""
    source = ARMS[arm]
    path = Path(source) if source.endswith(".yaml") else \
        ROOT / "src" / "maniplab" / "assets" / f"{source}.yaml"
    return yaml.safe_load(path.read_text())["joints"]


def bounds(spec: ml.ManipulatorSpec) -> tuple[np.ndarray, np.ndarray]:
    """Each joint's limits, ±0.5 (rad or m) where it has none."""
    lo = np.array([j.limits[0] if j.limits else -0.5 for j in spec.joints])
    hi = np.array([j.limits[1] if j.limits else 0.5 for j in spec.joints])
    return lo, hi


def start_pose(spec: ml.ManipulatorSpec) -> np.ndarray:
    """Mid-range on every joint: the pose the runs start from."""
    lo, hi = bounds(spec)
    return 0.5 * (lo + hi)


def goal_pose(spec: ml.ManipulatorSpec) -> np.ndarray:
    """A tenth of each joint's range beyond :func:`start_pose`: the pose whose end-effector the
    closed-loop move goes to."""
    lo, hi = bounds(spec)
    return start_pose(spec) + 0.1 * (hi - lo)


def random_pose(spec: ml.ManipulatorSpec, seed: int = 7) -> np.ndarray:
    lo, hi = bounds(spec)
    return np.random.default_rng(seed).uniform(lo, hi)


def numbers(values: np.ndarray) -> str:
    return ",".join(repr(float(v)) for v in values)


def command_limit(spec: ml.ManipulatorSpec) -> np.ndarray:
    from maniplab.sim.plant import Plant

    return np.asarray(Plant(spec).command_limit, dtype=float)


def held_commands(spec: ml.ManipulatorSpec, t: np.ndarray) -> dict[str, np.ndarray]:
    """A sine per joint (0.7-1.6 Hz): 30 % of the command limit on an actuator with one; on an
    unlimited torque source, the torque that holds the start pose plus 10 % of it (1 N·m at
    least)."""
    limit = command_limit(spec)
    hold = ml.AnalyticModel(spec).G(start_pose(spec))
    out = {}
    for j, name in enumerate(spec.joint_names):
        wave = np.sin(2.0 * np.pi * (0.7 + 0.3 * j) * t)
        if np.isfinite(limit[j]):
            out[name] = 0.3 * limit[j] * wave
        else:
            out[name] = hold[j] + max(0.1 * abs(hold[j]), 1.0) * wave
    return out


@functools.cache
def base_run(arm: str) -> Path:
    """A short run of the arm from :func:`start_pose`, held, under :func:`held_commands`."""
    spec = spec_of(arm)
    t = np.arange(0.0, 0.2 + 1e-9, 0.01)
    inputs = {j: ml.signals.held(t, u) for j, u in held_commands(spec, t).items()}
    run = ml.simulate(spec, inputs=inputs, duration=0.2, sample_dt=0.01,
                      initial={"q": start_pose(spec), "dP": "gravity"}, progress=False)
    path = _cache() / f"{arm.replace('/', '_')}.npz"
    run.save(path)
    return path


# --- references -----------------------------------------------------------------------------------


def mujoco_rigid(model: Any) -> Any:
    """``model`` with no damping, armature, friction loss or constraints: its rigid body only."""
    model.dof_damping[:] = 0.0
    model.dof_armature[:] = 0.0
    model.dof_frictionloss[:] = 0.0
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    return model


def mujoco_M_bias(model: Any, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = q, qd
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return M, data.qfrc_bias.copy()


def assert_close(actual: np.ndarray, reference: np.ndarray, what: str,
                 rel: float = 1e-9) -> None:
    err = float(np.linalg.norm(np.asarray(actual) - reference))
    assert err <= rel * np.linalg.norm(reference) + 1e-10, f"{what} differs by {err:.3e}"


def states(spec: ml.ManipulatorSpec) -> list[tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(3)
    return [(random_pose(spec, seed), rng.normal(0.0, 0.5, spec.n)) for seed in (1, 2)]


# --- the cells ------------------------------------------------------------------------------------


def cell_validate(arm: str, work: Path) -> str:
    out = cli("validate", ARMS[arm])
    n = len(raw_joints(arm))
    assert f"is valid ({n} joints" in out, out
    return out.strip()


def cell_info(arm: str, work: Path) -> str:
    out = cli("info", ARMS[arm])
    rows = {line.split()[0] for line in out.splitlines() if line.strip()}
    for joint in raw_joints(arm):
        name = joint.get("name")
        assert name is None or name in rows, f"no row for joint {name}"
        if "cylinder" in (joint.get("actuator") or {}):  # the pinned cylinder's detail line
            assert re.search(rf"^{name}: cylinder s .* r\(q\)", out, re.MULTILINE), name
    spec = spec_of(arm)
    assert (spec.supply is not None) == ("pump:" in out)
    return f"{len(spec.joints)} joints"


def cell_export_mjcf(arm: str, work: Path) -> str:
    """Plain MuJoCo loads the file: the masses, inertias and ranges of ``ml.build_model``, and
    the end-effector where the analytic model's forward kinematics puts it."""
    path = work / "arm.xml"
    cli("export", ARMS[arm], "-o", str(path))
    spec = spec_of(arm)
    model, ref = mujoco.MjModel.from_xml_path(str(path)), ml.build_model(spec)
    assert model.nq == spec.n == ref.nq
    for field in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "jnt_range"):
        np.testing.assert_array_equal(getattr(model, field), getattr(ref, field), err_msg=field)
    tanks = [j.actuator.tank_pressure for j in spec.joints
             if getattr(j.actuator, "cylinder", None) is not None]
    if tanks:  # the plant's initial state: the chambers at tank pressure, not MuJoCo's 0 Pa
        key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "initial")
        assert key >= 0, "no keyframe 'initial'"
        assert all(np.count_nonzero(model.key_act[key] == p) >= 2 for p in tanks), \
            model.key_act[key]
    data = mujoco.MjData(model)
    ee = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "end_effector")
    analytic = ml.AnalyticModel(spec)
    for seed in (1, 2):
        q = random_pose(spec, seed)
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(data.xpos[ee], analytic.fk(q)[:3, 3], rtol=0, atol=1e-9)
    return "masses, inertias, fk"


def cell_export_urdf(arm: str, work: Path) -> str:
    """Pinocchio's CRBA and RNEA on the file give the analytic model's M and G."""
    import pinocchio as pin

    path = work / "arm.urdf"
    cli("export", ARMS[arm], "-f", "urdf", "-o", str(path))
    spec = spec_of(arm)
    model = pin.buildModelFromUrdf(str(path))
    model.gravity.linear = np.array(spec.gravity, dtype=float)
    data, analytic = model.createData(), ml.AnalyticModel(spec)
    for q, _ in states(spec):
        x = np.array([v for value, joint in zip(q, model.joints[1:])
                      for v in ([math.cos(value), math.sin(value)] if joint.nq == 2 else [value])])
        upper = pin.crba(model, data, x).copy()
        M = np.triu(upper) + np.triu(upper, 1).T
        G = pin.computeGeneralizedGravity(model, data, x).copy()
        assert_close(M, analytic.M(q), "M", rel=1e-12)
        assert_close(G, analytic.G(q), "G", rel=1e-12)
    return "Pinocchio M, G"


def cell_model_python(arm: str, work: Path) -> str:
    path = work / "arm_model.py"
    cli("model", ARMS[arm], "-f", "python", "-o", str(path))
    found = importlib.util.spec_from_file_location(f"matrix_{path.stem}", path)
    assert found is not None and found.loader is not None
    module = importlib.util.module_from_spec(found)
    found.loader.exec_module(module)
    reference = mujoco_rigid(ml.build_model(spec_of(arm)))
    for q, qd in states(spec_of(arm)):
        M, bias = mujoco_M_bias(reference, q, qd)
        assert_close(module.M(q), M, "M")
        assert_close(module.bias(q, qd), bias, "bias")
    return "MuJoCo M, bias"


def cell_model_c(arm: str, work: Path) -> str:
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc, "no C compiler"
    source, lib = work / "arm_model.c", work / "libarm_model.so"
    cli("model", ARMS[arm], "-f", "c", "-o", str(source))
    subprocess.run([cc, "-O0", "-shared", "-fPIC", str(source), "-o", str(lib), "-lm"],
                   check=True)
    prefix = re.search(r"void (\w+)_M\(const double \*q", source.read_text())
    assert prefix, "no M function in the C file"
    so = ctypes.CDLL(str(lib))
    dp = ctypes.POINTER(ctypes.c_double)
    spec = spec_of(arm)
    n = spec.n

    def call(fn: str, shape: tuple[int, ...], *args: np.ndarray) -> np.ndarray:
        out = np.zeros(shape)
        ins = [np.ascontiguousarray(a, dtype=float) for a in args]
        getattr(so, f"{prefix[1]}_{fn}")(*[a.ctypes.data_as(dp) for a in ins],
                                         out.ctypes.data_as(dp))
        return out

    reference = mujoco_rigid(ml.build_model(spec))
    for q, qd in states(spec):
        M, bias = mujoco_M_bias(reference, q, qd)
        assert_close(call("M", (n, n), q), M, "M")
        assert_close(call("bias", (n,), q, qd), bias, "bias")
    return "MuJoCo M, bias"


def fmpy_python() -> Path:
    """The Python of ``.venv-fmpy`` (FMPy, no maniplab), made as tests/test_fmu.py makes it."""
    python = ROOT / ".venv-fmpy" / "bin" / "python"
    with open(Path("/tmp") / "maniplab-fmpy-venv.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if subprocess.run([str(python), "-c", "import fmpy"], capture_output=True,
                          check=False).returncode != 0:
            subprocess.run([sys.executable, "-m", "venv", "--clear", str(python.parents[1])],
                           check=True)
            subprocess.run([str(python), "-m", "pip", "install", "--quiet", "fmpy>=0.3.20"],
                           check=True)
    return python


def cell_fmu(arm: str, work: Path) -> str:
    """The FMU's model description has each joint's input and outputs and its binary; on :data:`FMPY_ARMS` (every arm in the full matrix) FMPy
    validates and runs it, its outputs ``ml.simulate``'s run to 1e-6."""
    import xml.etree.ElementTree as ET
    import zipfile

    from maniplab.sim.plant import Plant

    path = work / "arm.fmu"
    cli("fmu", ARMS[arm], "-o", str(path))
    spec = spec_of(arm)
    with zipfile.ZipFile(path) as fmu:
        root = ET.fromstring(fmu.read("modelDescription.xml"))
        identifier = root.find("CoSimulation").get("modelIdentifier")  # type: ignore[union-attr]
        assert f"binaries/linux64/{identifier}.so" in fmu.namelist()
    causality = {v.get("name"): v.get("causality") for v in root.iter("ScalarVariable")}
    for joint in spec.joint_names:
        assert causality.get(f"u.{joint}") == "input", joint
        assert causality.get(f"q.{joint}") == causality.get(f"qd.{joint}") == "output", joint
    if arm not in FMPY_ARMS and not FULL:
        return "model description, model"
    inputs = steps_and_sines(spec)
    run = ml.simulate(spec, inputs=inputs, duration=0.3, sample_dt=Plant(spec).dt,
                      progress=False)
    log = run_fmpy(fmpy_python(), [job(path, work / "out.npz", run, inputs)], work)
    assert "validation: []" in log and f"OK {path}" in log, log
    assert_matches(run, np.load(work / "out.npz"))
    return "FMPy = ml.simulate"


def cell_simulate(arm: str, work: Path) -> str:
    spec = spec_of(arm)
    limit = command_limit(spec)[0]
    amplitude = float(0.2 * limit) if np.isfinite(limit) else 1.0
    path = work / "run.npz"
    cli("simulate", ARMS[arm], f"--start={numbers(start_pose(spec))}", "--balanced",
        "--input", f"{spec.joint_names[0]}=step:{amplitude!r}@0.05", "--duration", "0.2",
        "--sample-dt", "0.01", "-o", str(path))
    run = ml.Run.load(path)
    assert run.t[-1] == pytest.approx(0.2) and np.all(np.isfinite(run.q))
    lo, hi = bounds(spec)
    limited = np.array([j.limits is not None for j in spec.joints])
    assert np.all((run.q >= lo - 1e-9) | ~limited) and np.all((run.q <= hi + 1e-9) | ~limited)
    np.testing.assert_allclose(run["ctrl"][:, 0], np.where(run.t >= 0.05, amplitude, 0.0))
    return "finite, within limits"


def cell_energy(arm: str, work: Path) -> str:
    """The balance of the arm's short run closes; the report names every pinned cylinder and
    the piston work it accounts is the work of the actuators' forces on their joints."""
    run_file = base_run(arm)
    cli("energy", str(run_file), "-o", str(work / "energy.png"), "--json", str(work / "e.json"))
    (report,) = json.loads((work / "e.json").read_text())
    spec = spec_of(arm)
    pinned = [j.name for j in spec.joints if getattr(j.actuator, "cylinder", None)]
    assert report["joints"] == pinned
    assert abs(report["residual"]) <= 1e-9 * max(report["pump"], 1.0)
    run = ml.Run.load(run_file)
    k = [spec.joint_index(j) for j in pinned]
    work_done = np.trapezoid(run["tau_act"][:, k] * run.qd[:, k], run.t, axis=0)
    scale = max(report["pump"], float(np.max(np.abs(report["terms"]["work"]))), 1.0)
    np.testing.assert_allclose(report["terms"]["work"], work_done, atol=0.05 * scale)
    return f"pump {report['pump']:.3g} J, residual {report['residual']:.1e} J"


def cell_sweep(arm: str, work: Path) -> str:
    spec = spec_of(arm)
    masses = sorted({spec.end_effector.mass, 1.5 * spec.end_effector.mass + 10.0})
    cli("sweep", ARMS[arm], f"--start={numbers(start_pose(spec))}", "--balanced",
        "--duration", "0.2", "--sample-dt", "0.02", "--processes", "1",
        "--vary", f"end_effector.mass={','.join(repr(m) for m in masses)}", "-o", str(work))
    runs = [ml.Run.load(p) for p in sorted(work.glob("*.npz"))]
    assert sorted(r.spec.end_effector.mass for r in runs) == masses
    assert all(np.all(np.isfinite(r.q)) for r in runs)
    return f"{len(runs)} runs"


def cell_crossval(arm: str, work: Path) -> str:
    out = cli("crossval", ARMS[arm], f"--start={numbers(start_pose(spec_of(arm)))}",
              "--duration", "0.3", "-o", str(work / "crossval.png"))
    found = re.search(r"largest deviation (\S+)", out)
    assert found and float(found[1]) < 1e-6, out
    return f"deviation {float(found[1]):.0e}"


def cell_tune(arm: str, work: Path) -> str:
    out = cli("tune", ARMS[arm], "-o", str(work / "tuned.yaml"))
    control = yaml.safe_load(out)["control"]
    assert control["rate"] > 0 and control["position"]["kp"] > 0
    tuned = ml.load_spec(work / "tuned.yaml")
    assert tuned.control is not None and tuned.joints == spec_of(arm).joints
    return f"{control['rate']:.0f} Hz"


def _control(arm: str, work: Path, *options: str, settle: float = 0.3,
             within: float = 2.1e-3) -> str:
    """A move of a tenth of each joint's range (its end-effector; on an arm whose tool hangs on
    passive joints, the point it hangs from) in 1.5 s: met within ``within`` (m) of the target,
    ``settle`` s after the move, by the analytic model's forward kinematics."""
    from maniplab.control.suspended import suspended

    spec = spec_of(arm)
    chain = suspended(spec)
    model = ml.AnalyticModel(chain)
    target = model.fk(goal_pose(spec)[:chain.n])[:3, 3]
    out = cli("control", ARMS[arm], f"--start={numbers(start_pose(spec))}",
              "--target", numbers(target), "--duration", "1.5", "--settle", str(settle),
              "--sample-dt", "0.01", *options, "-o", str(work))
    table = json.loads(out)
    assert table["health"]["verdict"] != "failed" and (work / "control.json").exists()
    run = ml.Run.load(work / "control.npz")
    assert np.all(np.isfinite(run.q))
    miss = np.linalg.norm(model.fk(run.q[-1][:chain.n])[:3, 3] - target)
    assert miss <= within, f"ends {miss * 1e3:.2f} mm off the target"
    return f"{miss * 1e3:.2f} mm"


def cell_control(arm: str, work: Path) -> str:
    return _control(arm, work)


PID_TIME_CONSTANTS = 15.0
"""The PID-only baseline is given this many of its slowest joint's time constants (1 / kp) after
the move to converge."""


def cell_control_pid(arm: str, work: Path) -> str:
    """The PID-only baseline is judged on where it ends: within 5 mm of the target 15 time
    constants of its slowest joint after the move (it converges slowly, each joint at its own
    spring's pace: the excavator's slew at kp = 0.24 /s needs a minute, and may hunt by a few
    millimetres against Coulomb friction); its tracking during the move is far worse than the
    cascade's and is not judged here (hence the RMS tolerance of 10 m)."""
    from maniplab.control.tuning import resolve

    kp = np.atleast_1d(resolve(spec_of(arm)).pid_only.kp)
    settle = PID_TIME_CONSTANTS / float(np.min(kp))
    return _control(arm, work, "--mode", "pid", "--tolerance", "5,10000", settle=settle,
                    within=5e-3)


def cell_loadchart(arm: str, work: Path) -> str:
    """Every pose's reach and height are its end-effector's by the analytic model (on an arm
    whose tool hangs on passive joints, its actuated chain's, at the suspension point)."""
    from maniplab.control.suspended import suspended

    path = work / "chart.json"
    cli("loadchart", ARMS[arm], "--points", "3", "-o", str(path))
    chart = json.loads(path.read_text())
    spec = suspended(spec_of(arm))
    analytic = ml.AnalyticModel(spec)
    up = -np.asarray(spec.gravity) / np.linalg.norm(spec.gravity)
    assert chart["poses"]
    for pose in chart["poses"]:
        if pose["payload_kg"] is None:  # no actuator with a limit: any payload is held
            assert pose["limited_by"] is None
        else:
            assert pose["payload_kg"] >= 0.0 and pose["limited_by"] in spec.joint_names
        p = analytic.fk(np.array(pose["q"]))[:3, 3]
        assert pose["height_m"] == pytest.approx(p @ up, abs=1e-9)
        assert pose["reach_m"] == pytest.approx(np.linalg.norm(p - (p @ up) * up), abs=1e-9)
    return f"{len(chart['poses'])} poses"


def cell_optimize(arm: str, work: Path) -> str:
    """A study of 4 candidates (the last body's mass within ±20 %, the smallest payload of a
    3-point chart maximised): the best written is the best of its evaluations, and its objective
    is the load chart's of the spec file it wrote."""
    spec = spec_of(arm)
    j = max(k for k, joint in enumerate(spec.joints) if joint.body is not None)
    mass = spec.joints[j].body.mass  # type: ignore[union-attr]
    study = work / "study.yaml"
    study.write_text(yaml.safe_dump({
        "spec": str(Path(ARMS[arm]).resolve()) if Path(ARMS[arm]).exists() else ARMS[arm],
        "seed": 1, "budget": 4,
        "variables": [{"path": f"joints.{j}.body.mass", "low": 0.8 * mass, "high": 1.2 * mass}],
        "statics": {"points": 3},
        "objectives": [{"metric": "payload_min", "sense": "max"}]}))
    out = json.loads(cli("optimize", str(study), "-o", str(work / "out"), "--processes", "1"))
    rows = json.loads((work / "out" / "evaluations.json").read_text())
    search = [r for r in rows if r["phase"] == "search" and r["feasible"]]
    assert out["evaluations"] == 4 and len(search) == 4

    def held(value: float | None) -> float:
        return math.inf if value is None else value

    best = held(out["best"]["metrics"]["payload_min"])
    assert best == max(held(r["payload_min"]) for r in search)
    chart = ml.load_chart(work / "out" / "best.yaml", points=3)
    assert float(np.min(chart.payload)) == pytest.approx(best, rel=1e-9)
    return f"{best:.4g} kg"


def cell_render(arm: str, work: Path) -> str:
    from PIL import Image

    path = work / "clip.gif"
    cli("render", str(base_run(arm)), "-o", str(path), "--width", "96", "--height", "72",
        "--fps", "10", "--no-antialias", "--no-text")
    with Image.open(path) as image:
        frames = image.n_frames
        pixels = np.asarray(image.convert("RGB")).astype(int)
    assert frames >= 2
    assert np.count_nonzero(pixels.max(axis=2) - pixels.min(axis=2) > 80) > 20, "no arm drawn"
    return f"{frames} frames"


def cell_identify(arm: str, work: Path) -> str:
    """A synthetic experiment (the arm with a 20 % heavier payload, 0.4 s of sines, the noise of
    tests/identify_data.py) fitted for the payload: the truth within 5 %, and within the 95 %
    interval widened twofold (about 4σ: a cell of 19 arms must not miss by chance)."""
    from maniplab.identification import save_csv

    spec = spec_of(arm)
    start = spec.end_effector.mass or 10.0  # a payload of 0 needs a first guess (--set)
    truth = 1.2 * start
    t = np.arange(0.0, 0.4 + 1e-9, 0.002)
    inputs = {j: ml.signals.held(t, u) for j, u in held_commands(spec, t).items()}
    run = ml.simulate(spec.with_overrides({"end_effector.mass": truth}), inputs=inputs,
                      duration=0.4, sample_dt=0.002,
                      initial={"q": start_pose(spec), "dP": "gravity"}, progress=False)
    save_csv(run, work / "rig.csv")
    with open(work / "rig.csv") as file:  # measurement noise as tests/identify_data.py's
        header = file.readline().strip().split(",")
    table = np.loadtxt(work / "rig.csv", delimiter=",", skiprows=1)
    rng = np.random.default_rng(0)
    for k, column in enumerate(header):
        sigma = NOISE.get(column.split(".")[0])
        if sigma:
            table[:, k] += rng.normal(0.0, sigma, len(table))
    np.savetxt(work / "rig.csv", table, delimiter=",", header=",".join(header), comments="",
               fmt="%.17g")
    out = cli("identify", ARMS[arm], str(work / "rig.csv"), "--params",
              f"end_effector.mass[0:{4.0 * truth!r}]", "--set", f"end_effector.mass={start!r}",
              "-o", str(work / "fitted.yaml"),
              "--figure", str(work / "fit.png"))
    fitted = ml.load_spec(work / "fitted.yaml").end_effector.mass
    row = re.search(r"\| end_effector\.mass \| \S+ \| \S+ \| \[(\S+), (\S+)\]", out)
    assert row, out
    low, high = float(row[1]), float(row[2])  # 95 %: about ±2σ; the truth within ±4σ
    assert fitted == pytest.approx(truth, rel=0.05), out
    assert fitted - (high - low) <= truth <= fitted + (high - low), \
        f"the 95 % interval [{low:.6g}, {high:.6g}] misses the truth {truth:.6g} by more than " \
        f"twice its width (fitted {fitted:.6g})"
    return f"{fitted:.4g} kg of {truth:.4g}"


def cell_gui_arm3d(arm: str, work: Path) -> str:
    """The GUI's 3D arm (viser meshes) at a random pose: each mesh where MuJoCo's forward pass
    on ``ml.build_model`` puts its geom."""
    from maniplab.gui.arm3d import Arm3D
    from maniplab.gui.replay import recording_server

    spec = spec_of(arm)
    q = random_pose(spec, 5)
    model = ml.build_model(spec)
    data = mujoco.MjData(model)
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    with recording_server() as server:
        view = Arm3D(server.scene, "/arm", spec)
        view.pose(q)
        assert view._meshes, "no geometry drawn"
        for geom, _ in view._meshes:
            name = model.geom(geom).name
            ref = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
            position, rotation = view.drawn_pose(geom)  # its body's frame and its place in it
            np.testing.assert_allclose(position, data.geom_xpos[ref], atol=1e-9)
            np.testing.assert_allclose(rotation.ravel(), data.geom_xmat[ref], atol=1e-9)
    return f"{len(view._meshes)} meshes"


def cell_replay_html(arm: str, work: Path) -> str:
    """The HTML replay's player data for a run started at a random pose: at its first frame each
    drawn geom's pose is MuJoCo's on ``ml.build_model`` (float32), and the page is written."""
    from maniplab.gui.player import POSE, player_data, replay_html

    spec = spec_of(arm)
    q = random_pose(spec, 6)
    run = ml.simulate(spec, duration=0.01, initial={"q": q})
    meta, blob = player_data([run])
    _, offset, size = meta["blob"][meta["runs"][0]["arrays"]["poses"]]
    poses = np.frombuffer(blob, np.float32, size, offset).reshape(meta["frames"], -1, POSE)
    model = ml.build_model(spec)
    data = mujoco.MjData(model)
    data.qpos[:] = run.q[0]
    mujoco.mj_forward(model, data)
    quat = np.empty(4)
    drawn = [g for g in range(model.ngeom) if model.geom_type[g] != mujoco.mjtGeom.mjGEOM_PLANE]
    assert drawn, "no geometry drawn"
    for p, geom in enumerate(drawn):
        np.testing.assert_allclose(poses[0, p, :3], data.geom_xpos[geom], atol=1e-5)
        mujoco.mju_mat2Quat(quat, data.geom_xmat[geom])
        assert abs(float(np.dot(poses[0, p, 3:7], quat))) == pytest.approx(1.0, abs=1e-5)
    assert "window.maniplabPlayer" in replay_html([run])
    return f"{len(drawn)} geoms, {len(meta['runs'][0]['parts']) - len(drawn)} cylinder parts"


CELLS: dict[str, Callable[[str, Path], str]] = {
    command: globals()[f"cell_{command.replace('-', '_')}"] for command in COMMANDS}


class Outcome(NamedTuple):
    kind: str  # "ok", "refused" (exit 2 or 3, one line) or "error" (anything else)
    text: str


def outcome(arm: str, command: str, work: Path) -> Outcome:
    try:
        return Outcome("ok", CELLS[command](arm, work))
    except Refused as refused:
        return Outcome("refused", refused.line)
    except Exception as exc:  # noqa: BLE001 (the cell's failure is its outcome)
        return Outcome("error", f"{type(exc).__name__}: {exc}".splitlines()[0])


# --- the test -------------------------------------------------------------------------------------


def _collected() -> list[tuple[str, str]]:
    """Every cell; unless :data:`FULL`, the commands of :data:`QUICK` only on its arms."""
    return [(arm, command) for arm in ARMS for command in COMMANDS
            if FULL or arm in QUICK.get(command, (arm,))]


@pytest.mark.parametrize(("arm", "command"), _collected())
def test_cell(arm: str, command: str, tmp_path: Path) -> None:
    expected = EXPECTED.get((arm, command))
    if expected is None:
        CELLS[command](arm, tmp_path)  # succeeds, its checks pass
        return
    got = outcome(arm, command, tmp_path)
    assert got.kind != "ok", f"{arm} {command} now succeeds: take it out of EXPECTED"
    if expected.kind == "refused":
        assert got.kind == "refused", got.text
    assert expected.reason in got.text, got.text


def test_expected_names_only_arms_and_commands_of_the_matrix() -> None:
    for arm, command in EXPECTED:
        assert arm in ARMS and command in COMMANDS, (arm, command)
    assert all(e.kind in ("refused", "defect") for e in EXPECTED.values())


# --- defects the matrix found, fixed ----------------------------------------------------------------


@pytest.mark.parametrize("arm", ["arms/mixed/forestry_grapple", "arms/erector7"])
def test_a_load_chart_of_an_arm_whose_last_joint_turns_only_the_payload(arm: str,
                                                                         tmp_path: Path) -> None:
    """Before: refused ("joint rotator drives no mass or inertia"): the chart compiled the arm
    without its payload, and checked that model as a simulation's."""
    assert cell_loadchart(arm, tmp_path).endswith("poses")


def test_identify_takes_the_first_guess_its_refusal_asks_for(tmp_path: Path) -> None:
    """Before: a payload of 0 was refused with "give a first guess with --set", an option
    ``maniplab identify`` did not have (argparse refused it, exit 2)."""
    with pytest.raises(Refused, match="give a first guess with --set"):
        cli("identify", "planar2", str(base_run("planar2")), "--params", "end_effector.mass")
    # the planar2 identify cell fits from the guess it gives with --set


# --- the table ------------------------------------------------------------------------------------


def table(cells: dict[tuple[str, str], Outcome]) -> str:
    """The matrix as Markdown: ✔ or a note number per cell, the notes below."""
    notes: list[str] = []
    rows = ["| arm | " + " | ".join(COMMANDS) + " |", "|---" * (len(COMMANDS) + 1) + "|"]
    for arm in ARMS:
        marks = []
        for command in COMMANDS:
            got = cells[(arm, command)]
            if got.kind == "ok":
                marks.append("✔")
                continue
            word = {"refused": "refused", "defect": "DEFECT", "error": "FAILED"}[got.kind]
            note = f"{word}: {got.text}"
            if note not in notes:
                notes.append(note)
            marks.append(f"{word} ({notes.index(note) + 1})")
        rows.append(f"| {arm} | " + " | ".join(marks) + " |")
    lines = [*rows, ""]
    lines += [f"{k}. {note}" for k, note in enumerate(notes, 1)]
    return "\n".join(lines)


def expected_table() -> str:
    """The table the tests assert: ✔ where EXPECTED has no entry."""
    return table({(arm, command): (Outcome(e.kind, f"“{e.reason}”: {e.why}") if (
        e := EXPECTED.get((arm, command))) else Outcome("ok", ""))
        for arm in ARMS for command in COMMANDS})


def documented_table() -> str:
    text = DOC.read_text()
    assert SECTION in text, f"no section {SECTION!r} in {DOC}"
    body = text.split(SECTION, 1)[1].split("\n## ", 1)[0]
    start, end = "<!-- matrix: begin -->", "<!-- matrix: end -->"
    return body.split(start, 1)[1].split(end, 1)[0].strip()


def test_the_documented_table_is_the_expected_one() -> None:
    assert documented_table() == expected_table(), \
        "regenerate it: python tests/test_matrix.py --write"


def _run_cell(key: tuple[str, str]) -> tuple[tuple[str, str], Outcome, float]:
    import time

    begin = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="maniplab-cell-") as folder:
        got = outcome(*key, Path(folder))
    return key, got, time.perf_counter() - begin


def main() -> int:
    """Run every cell (the full matrix), print the table of what happened (the reasons as the commands said them)
    and compare it with EXPECTED; ``--write`` puts EXPECTED's table into the docs."""
    import concurrent.futures
    import multiprocessing

    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("--write", action="store_true",
                        help="only write EXPECTED's table into " + str(DOC) + " (no run)")
    parser.add_argument("-j", "--jobs", type=int, default=2, help="processes (default 2)")
    parser.add_argument("--arms", help="comma-separated arm ids (default: all)")
    args = parser.parse_args()
    if args.write:
        text = DOC.read_text()
        block = f"<!-- matrix: begin -->\n{expected_table()}\n<!-- matrix: end -->"
        head, rest = text.split(SECTION, 1)
        body, *tail = rest.split("\n## ", 1)
        body = re.sub(r"<!-- matrix: begin -->.*<!-- matrix: end -->", lambda _: block, body,
                      flags=re.DOTALL)
        DOC.write_text(head + SECTION + body + ("\n## " + tail[0] if tail else ""))
        return 0
    arms = args.arms.split(",") if args.arms else list(ARMS)
    keys = [(arm, command) for arm in arms for command in COMMANDS]
    cells: dict[tuple[str, str], Outcome] = {}
    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(args.jobs, mp_context=context) as pool:
        for key, got, seconds in pool.map(_run_cell, keys):
            cells[key] = got
            print(f"{key[0]:28} {key[1]:13} {seconds:5.1f} s {got.kind:8} {got.text[:140]}",
                  file=sys.stderr, flush=True)
    differ = []
    for key, got in cells.items():
        e = EXPECTED.get(key)
        if (e is None) != (got.kind == "ok") or (e is not None and e.reason not in got.text):
            differ.append(f"{key}: expected {e}, got {got}")
    if set(arms) == set(ARMS):
        print(table(cells))
    print("\n".join(differ) or "every cell as EXPECTED says", file=sys.stderr)
    return 1 if differ else 0


if __name__ == "__main__":
    os.environ["MANIPLAB_MATRIX"] = "full"  # also the spawned processes' value
    FULL = True
    sys.exit(main())
