"""Building the FMU: the plant's C code compiled with the arm's settings, MuJoCo bundled, zipped.

An FMU is a zip archive:

- ``modelDescription.xml``: the variables, units, the default experiment (:mod:`.description`);
- ``binaries/linux64/<id>.so``: ``fmu.c`` (the FMI functions) with maniplab's plant and engine
  plugins (every ``maniplab_native/*.c``), compiled for this arm (``fmu_config.h``), and linked to
- ``binaries/linux64/libmujoco.so.<version>``: the installed mujoco wheel's library, found next to
  the FMU's library (rpath ``$ORIGIN``), so the target needs neither Python nor MuJoCo;
- ``resources/model.xml``: the arm's MJCF with the parameters as tokens (:mod:`.template`);
- ``documentation/``: MuJoCo's licence, which its redistribution requires.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import shutil
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from maniplab.atomic import atomic_path
from maniplab.builtin import resolve_spec
from maniplab.fmu.description import model_description
from maniplab.fmu.errors import FmuError
from maniplab.fmu.template import Parameter, fill, model_template
from maniplab.fmu.variables import Variable, variables
from maniplab.model.export import c_identifier
from maniplab.progress import Progress
from maniplab.sim.plant import Plant, SpecLike
from maniplab_native import build as native_build

PLATFORM = "linux64"
"""The one platform folder this builder compiles for (the machine it runs on must be it)."""

_NATIVE = Path(native_build.__file__).resolve().parent
_FMU_C = _NATIVE / "fmu"
_KIND = {"q": "ML_V_Q", "qd": "ML_V_QD", "act": "ML_V_ACT", "mode": "ML_V_MODE", "u": "ML_V_U",
         "param": "ML_V_PARAM", "q0": "ML_V_Q0"}


def build_fmu(spec: SpecLike, path: str | os.PathLike[str], *, step: float | None = None,
              integrator: str = "RK4", progress: bool | None = None) -> Path:
    """Write the arm's plant as an FMI 2.0 co-simulation FMU.

    Args:
        spec: a spec, spec file or built-in name.
        path: the ``.fmu`` file to write (atomically: nothing under that name if it fails).
        step: the FMU's step, s: the inputs are held over it, as ``ml.simulate``'s ``dt``
            (default: the step ``ml.simulate`` takes for this arm). A communication step must be
            a whole number of these.
        integrator: MuJoCo's integrator, as :class:`~maniplab.sim.plant.Plant` takes it.
        progress: show the stages on stderr (None: a bar on a terminal, lines in a log).

    Returns:
        The path written.

    Raises:
        FmuError: an actuator written in Python, not Linux x86-64, no C compiler, the compiler
            failed; one line.
        SpecError, InputError, InstabilityError: as :class:`~maniplab.sim.plant.Plant`.
    """
    _check_platform()
    spec = resolve_spec(spec)
    bar = Progress(3, f"maniplab: building the FMU of {spec.name}", enabled=progress)
    try:
        bar.start("the plant")
        plant = Plant(spec, dt=step, integrator=integrator)
        _check_native(plant)
        template, params = model_template(plant)
        _check_template(plant, template, params)
        table = variables(plant, params)
        bar.step("the plant")
        bar.start("compiling")
        with tempfile.TemporaryDirectory(prefix="maniplab-fmu-") as tmp:
            guid = _guid(template, table, plant)
            identifier = c_identifier(spec.name)  # the library's name
            folder = Path(tmp)
            lib = _compile(folder, identifier, config_header(plant, params, table, guid))
            bar.step("compiling")
            bar.start("packaging")
            description = model_description(
                name=spec.name, identifier=identifier, guid=guid, dt=plant.dt, variables=table,
                description=f"maniplab plant of arm {spec.name}: MuJoCo with hydraulic actuators, "
                            "friction and limits; inputs held over steps of "
                            f"{plant.dt:g} s ({plant.substeps} MuJoCo steps each)")
            out = _package(Path(path), identifier, lib, description, template)
            bar.step("packaging")
    finally:
        bar.close()
    return out


def _check_platform() -> None:
    machine = platform.machine().lower()
    if not (sys.platform.startswith("linux") and machine in ("x86_64", "amd64")):
        raise FmuError(f"maniplab builds FMUs for Linux x86-64 ({PLATFORM}); this machine is "
                       f"{sys.platform} {machine}")


def _check_native(plant: Plant) -> None:
    """An FMU holds no Python: every actuator must be MuJoCo's or a native plugin."""
    for j in plant.python_actuators:
        name, act = plant.joint_names[j], plant.actuators[j]
        raise FmuError(f"{plant.spec.name}: joint {name}: its actuator ({act.label()}) is written "
                       "in Python, and an FMU runs without Python: give it a MuJoCo engine "
                       "plugin (see the how-to 'A custom actuator plugin')")


# the arrays of the compiled model the template must reproduce exactly (dynamics, not drawing)
_COMPARED = ("body_mass", "body_inertia", "body_ipos", "body_iquat", "body_pos", "body_quat",
             "jnt_type", "jnt_axis", "jnt_pos", "dof_damping", "dof_armature", "actuator_trntype",
             "actuator_dyntype", "actuator_gaintype", "actuator_biastype", "actuator_gainprm",
             "actuator_biasprm", "actuator_ctrlrange", "actuator_gear", "actuator_actnum",
             "actuator_plugin", "site_pos", "wrap_objid", "tendon_num")


def _check_template(plant: Plant, template: str, params: list[Parameter]) -> None:
    """The template, with the spec's values, must compile to the plant's model (a guard against a
    silently different arm in the FMU)."""
    model = mujoco.MjModel.from_xml_string(fill(template, {p.name: p.default for p in params}))
    mine = plant.model
    for field in _COMPARED:
        if not np.array_equal(getattr(model, field), getattr(mine, field)):
            raise FmuError(f"{plant.spec.name}: the FMU's model text compiles to a different "
                           f"{field} than the plant's model (a maniplab bug: please report it)")
    if _plugin_values(model) != _plugin_values(mine):
        raise FmuError(f"{plant.spec.name}: the FMU's model has different plugin configs")
    for field in ("timestep", "integrator", "disableflags", "gravity"):
        if not np.array_equal(getattr(model.opt, field), getattr(mine.opt, field)):
            raise FmuError(f"{plant.spec.name}: the FMU's model has a different option {field}")


def _plugin_values(model: mujoco.MjModel) -> list[float | str]:
    """The plugins' config values, numbers as floats (the FMU writes them with %.17g)."""
    words = bytes(np.asarray(model.plugin_attr, dtype=np.uint8)).split(b"\0")
    out: list[float | str] = []
    for word in words:
        try:
            out.append(float(word))
        except ValueError:
            out.append(word.decode())
    return out


def _guid(template: str, table: list[Variable], plant: Plant) -> str:
    digest = hashlib.sha256(template.encode())
    digest.update(repr([(v.name, v.kind, v.index) for v in table]).encode())
    digest.update(repr((plant.dt, plant.substeps, plant.native_config())).encode())
    return "{" + str(uuid.UUID(bytes=digest.digest()[:16])) + "}"


# --- the C configuration -------------------------------------------------------------------------
def _c_double(x: float) -> str:
    if math.isinf(x):
        return "INFINITY" if x > 0 else "-INFINITY"
    return repr(float(x))


def _c_array(ctype: str, name: str, values: list[Any], fmt: Any) -> str:
    items = [fmt(v) for v in values] or ['""' if "char" in ctype else fmt(0)]
    return f"static const {ctype} {name}[{len(items)}] = {{{', '.join(items)}}};"


def config_header(plant: Plant, params: list[Parameter], table: list[Variable],
                  guid: str) -> str:
    """``fmu_config.h``: the arm's settings as C constants for ``fmu.c``."""
    c = plant.native_config()
    act0 = plant.data.act.tolist()  # after the plant's reset: the actuators' initial states
    text = json.dumps
    lines = [
        "/* generated by maniplab.fmu for arm " + text(plant.spec.name)[1:-1] + " */",
        f"#define ML_FMU_GUID {text(guid)}",
        f"#define ML_FMU_BUILD {text(guid[1:9])}",
        f"#define ML_FMU_N {plant.n}", f"#define ML_FMU_NA {plant.model.na}",
        f"#define ML_FMU_SUBSTEPS {plant.substeps}", f"#define ML_FMU_DT {plant.dt!r}",
        f"#define ML_FMU_NPARAM {len(params)}", f"#define ML_FMU_NPARAM1 {max(1, len(params))}",
        f"#define ML_FMU_NBOUND {len(c['bound_adr'])}", f"#define ML_FMU_NVAR {len(table)}",
        _c_array("char* const", "kJoint", list(plant.joint_names), text),
        _c_array("char* const", "kParamName", [p.name for p in params], text),
        _c_array("double", "kParamDefault", [p.default for p in params], _c_double),
        _c_array("int", "kParamPositive", [int(p.positive) for p in params], str),
        _c_array("double", "kQ0Default", [0.0] * plant.n, _c_double),
        _c_array("double", "kAct0", act0, _c_double),
        _c_array("int", "kVarKind", [v.kind for v in table], _KIND.__getitem__),
        _c_array("int", "kVarIndex", [v.index for v in table], str),
    ]
    for field in ("lower", "upper", "command_limit", "coulomb", "stiction", "stribeck",
                  "stick_velocity", "bound_value", "rod_coulomb", "rod_stiction", "rod_stribeck",
                  "rod_viscous", "rod_stick_velocity"):
        lines.append(_c_array("double", _c_name(field), c[field], _c_double))
    for field in ("slip", "bound_adr", "bound_joint", "rod"):
        lines.append(_c_array("int", _c_name(field), c[field], str))
    return "\n".join(lines) + "\n"


def _c_name(field: str) -> str:
    return "k" + "".join(part.capitalize() for part in field.split("_"))


# --- compiling and packaging ---------------------------------------------------------------------
def _compile(folder: Path, identifier: str, header: str) -> Path:
    """Compile the FMU's library into ``folder/binaries/linux64`` next to a copy of libmujoco."""
    mujoco_dir, libmujoco = native_build.mujoco_paths()
    compilers = native_build.compiler_candidates()
    if not compilers:
        raise FmuError("building an FMU needs a C compiler and none was found (tried $MANIPLAB_CC, "
                       "$CC, cc, gcc, clang): install one, e.g. apt-get install gcc")
    (folder / "fmu_config.h").write_text(header)
    binaries = folder / "binaries" / PLATFORM
    binaries.mkdir(parents=True)
    shutil.copy2(libmujoco, binaries / libmujoco.name)
    target = binaries / f"{identifier}.so"
    sources = [str(p) for p in native_build.sources() if p.suffix == ".c"]
    argv = [*compilers[0], *native_build.CFLAGS, "-D_POSIX_C_SOURCE=200809L", "-DML_NO_LIB_INIT",
            "-fvisibility=hidden", "-pthread", f"-I{_NATIVE}", f"-I{_FMU_C}", f"-I{folder}",
            f"-I{mujoco_dir / 'include'}", str(_FMU_C / "fmu.c"), *sources, "-o", str(target),
            f"-L{binaries}", f"-l:{libmujoco.name}", "-Wl,-rpath,$ORIGIN", "-Wl,-Bsymbolic", "-lm"]
    proc = native_build.run_compiler(argv, timeout=600)
    if proc.returncode != 0:
        errors = [line for line in proc.stderr.splitlines() if "error" in line]
        raise FmuError(f"the C compiler failed on the FMU: {(errors or ['(no message)'])[0]}")
    return target


def _package(path: Path, identifier: str, lib: Path, description: str, template: str) -> Path:
    """Zip the FMU into ``path`` atomically."""
    binaries = lib.parent
    licences = native_build.mujoco_licences()
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as fmu:
        fmu.writestr("modelDescription.xml", description)
        for file in sorted(binaries.iterdir()):
            fmu.write(file, f"binaries/{PLATFORM}/{file.name}")
        fmu.writestr("resources/model.xml", template)
        for licence in licences:
            fmu.write(licence, f"documentation/licenses/MuJoCo-{licence.name}")
    return path
