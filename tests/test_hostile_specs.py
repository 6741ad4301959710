"""Hostile spec files, names, values and run files (issue 12): each is refused with one line
naming the file, joint and field, fast and in little memory, or handled exactly; none runs code.

- YAML bombs (nested aliases), huge files, devices and pipes: refused before they are read or
  expanded, in a child process whose address space is capped, so a regression fails with a
  MemoryError instead of eating the machine;
- names that would inject MJCF (``-->``, ``<include>``, quotes, control characters): refused, or
  the exported file loads into exactly the model ``ml.build_model`` makes;
- numbers whose use overflows (1e308, subnormals, NaN): refused naming the field;
- plugin modules: a spec or a run file never imports one; only ``--plugin``,
  ``MANIPLAB_PLUGINS`` or ``ml.load_plugins`` do, and ``python -m maniplab`` does not look in the
  current folder.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

import maniplab as ml
from maniplab.actuators import registry
from maniplab.cli import main
from maniplab.spec.actuator import UnresolvedActuator

ROOT = Path(__file__).resolve().parents[1]
MEMORY_CAP = 2 * 2**30  # bytes of address space for a child: validating a spec needs ~0.2 GB
FAST = 30.0  # s: a refusal is a matter of seconds even on a loaded machine (~1 s alone)
MAIN = "import sys; from maniplab.cli import main; sys.exit(main(sys.argv[1:]))"

JOINTS = """\
joints:
  - {name: q1, type: R, axis: z, body: {length: 1.0, mass: 2.0}}
  - {name: q2, type: R, axis: y, body: {length: 0.5, mass: 1.0}, friction: {model: lugre, coulomb: 1.0}}
"""


def cli(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, str, str]:
    """Run the ``maniplab`` command in this process: (status, stdout, stderr)."""
    status = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return status, out, err


def child(*args: str | Path, cwd: Path, env: dict[str, str] | None = None,
          module: bool = False) -> subprocess.CompletedProcess[str]:
    """Run ``maniplab ARGS`` in a child process: ``python -m maniplab`` with ``module``, else the
    CLI's main with the address space capped at MEMORY_CAP bytes."""
    capped = ("import resource; "
              f"resource.setrlimit(resource.RLIMIT_AS, ({MEMORY_CAP}, {MEMORY_CAP})); {MAIN}")
    code = ["-m", "maniplab"] if module else ["-c", capped]
    return subprocess.run([sys.executable, *code, *map(str, args)], cwd=cwd, check=False,
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, **(env or {})})


def assert_one_line(err: str, *words: str) -> None:
    """stderr is one line (no traceback) holding every word."""
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for word in words:
        assert word in err, f"{word!r} not in {err!r}"


# --- 6. bounded input ---------------------------------------------------------------------------


def billion_laughs(levels: int = 9) -> str:
    """Nested aliases: 9 levels of 9 make 9**9 = 387 million strings from 500 bytes."""
    lines = ["name: lol", 'a0: &a0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    lines += [f"a{i}: &a{i} [" + ",".join([f"*a{i - 1}"] * 9) + "]" for i in range(1, levels)]
    return "\n".join([*lines, f"joints: *a{levels - 1}"]) + "\n"


@pytest.mark.parametrize(("text", "words"), [
    (billion_laughs(), ["bomb.yaml:", "more than 100000 values"]),
    ("name: a\njoints: &j [*j]\n", ["bomb.yaml:2", "refers to an anchor that contains it"]),
    ("name: w\njoints: [" + ",".join(["0"] * 300_000) + "]\n",
     ["bomb.yaml:2", "more than 100000 values"]),
    ("name: d\njoints: " + "[" * 100_000 + "]" * 100_000 + "\n", ["nested too deeply"]),
], ids=["billion-laughs", "recursive-alias", "wide", "deep"])
def test_yaml_bombs_are_refused_fast_in_little_memory(tmp_path, text, words) -> None:
    (tmp_path / "bomb.yaml").write_text(text)
    start = time.monotonic()
    result = child("validate", "bomb.yaml", cwd=tmp_path)
    assert time.monotonic() - start < FAST
    assert result.returncode == 2
    assert_one_line(result.stderr, *words)


def test_a_huge_file_is_refused_by_its_size_before_it_is_read(tmp_path) -> None:
    with open(tmp_path / "spec.yaml", "wb") as f:
        f.truncate(50 * 2**20)  # 50 MiB, sparse: made in no time, refused unread
    start = time.monotonic()
    result = child("validate", "spec.yaml", cwd=tmp_path)
    assert time.monotonic() - start < FAST and result.returncode == 2
    assert_one_line(result.stderr, "spec.yaml: 52.5 MB is larger than the 1 MB a spec may have")


def test_a_file_just_over_the_bound_is_refused_and_one_under_it_is_parsed(tmp_path, capsys) -> None:
    spec = "name: padded\n" + JOINTS
    (tmp_path / "over.yaml").write_text(spec + "#" * (1_000_001 - len(spec)))
    (tmp_path / "under.yaml").write_text(spec + "#" * (1_000_000 - len(spec)))
    status, _, err = cli(capsys, "validate", tmp_path / "over.yaml")
    assert status == 2
    assert_one_line(err, "over.yaml: 1.1 MB is larger than the 1 MB a spec may have")
    status, out, _ = cli(capsys, "validate", tmp_path / "under.yaml")
    assert status == 0 and "ok: padded is valid" in out


@pytest.mark.parametrize("kind", ["/dev/zero", "fifo", "stdin-pipe"])
def test_devices_and_pipes_are_refused_without_reading(tmp_path, kind) -> None:
    path = "/dev/zero" if kind == "/dev/zero" else "/dev/stdin" if kind == "stdin-pipe" else "f"
    if kind == "fifo":
        os.mkfifo(tmp_path / "f")  # no writer: opening it would block forever
    start = time.monotonic()
    with subprocess.Popen(["yes"], stdout=subprocess.PIPE) as endless:  # stdin that never ends
        result = subprocess.run([sys.executable, "-c", MAIN, "validate", path], check=False,
                                stdin=endless.stdout, cwd=tmp_path, capture_output=True,
                                text=True, timeout=120)
        endless.kill()
    assert time.monotonic() - start < FAST and result.returncode == 2
    assert_one_line(result.stderr, "is not a regular file", "expected a YAML spec file")


def test_anchors_aliases_and_merge_keys_keep_working(tmp_path, capsys) -> None:
    (tmp_path / "arm.yaml").write_text(textwrap.dedent("""\
        name: anchors
        joints:
          - {name: q1, type: R, axis: z, body: &link {length: 1.0, mass: 2.0}}
          - {name: q2, type: R, axis: y, body: {<<: *link, mass: 3.0}}
          - {name: q3, type: R, axis: y, body: *link}
        """))
    status, out, _ = cli(capsys, "validate", tmp_path / "arm.yaml")
    assert status == 0 and "3 joints" in out
    masses = [j.body.mass for j in ml.load_spec(tmp_path / "arm.yaml").joints]
    assert masses == [2.0, 3.0, 2.0]


# --- 7. names that reach the MJCF ---------------------------------------------------------------

MODEL_ARRAYS = ("body_mass", "body_inertia", "body_pos", "body_ipos", "body_iquat", "jnt_type",
                "jnt_axis", "jnt_range", "jnt_limited", "dof_damping", "actuator_gainprm",
                "actuator_biasprm", "actuator_gear", "actuator_ctrlrange", "actuator_dyntype",
                "actuator_actnum", "geom_size", "geom_type", "site_pos")


def assert_same_model(loaded: mujoco.MjModel, built: mujoco.MjModel) -> None:
    """Every count, numeric array that matters and name of the two models are equal."""
    for count in ("nbody", "njnt", "nu", "ngeom", "nsite", "na", "nplugin"):
        assert getattr(loaded, count) == getattr(built, count), count
    np.testing.assert_array_equal(loaded.opt.gravity, built.opt.gravity)
    assert loaded.opt.timestep == built.opt.timestep
    for name in MODEL_ARRAYS:
        np.testing.assert_array_equal(getattr(loaded, name), getattr(built, name), err_msg=name)
    assert bytes(loaded.names) == bytes(built.names)


def exported_or_refused(capsys, tmp_path: Path, spec_file: Path, field: str) -> str:
    """Export ``spec_file``; either it is refused in one line naming ``field`` ('refused'), or
    the MJCF loads into the model build_model makes ('same')."""
    status, _, err = cli(capsys, "export", spec_file, "-o", tmp_path / "arm.xml")
    if status == 2:
        assert_one_line(err, f"field '{field}'")
        return "refused"
    assert status == 0, err
    loaded = mujoco.MjModel.from_xml_path(str(tmp_path / "arm.xml"))
    assert_same_model(loaded, ml.build_model(ml.load_spec(spec_file)))
    return "same"


HOSTILE_TEXT = [
    "-->", "<!--", "--", "---", "-", "trailing-", 'x --> <option gravity="0 0 50"/> <!-- y',
    '<include file="/etc/passwd"/>', "<![CDATA[ x ]]>", "]]>", '<?xml version="1.0"?>',
    "it's \"quoted\"", "&", "&amp;", "&#x3C;!--", "&xxe;", "two\nlines", "cr\rreturn",
    "nul\x00byte", "bell\x07", "rtl\u202eevil", "rlm\u200fmark", "bom\ufeff", "sep\u2028line",
    "ünïcødé 名前 🚀", "x" * 10_000,
]
NOT_ONE_LINE = {"two\nlines", "cr\rreturn", "nul\x00byte", "bell\x07", "rtl\u202eevil",
                "rlm\u200fmark", "bom\ufeff", "sep\u2028line"}


@pytest.mark.parametrize("name", HOSTILE_TEXT, ids=range(len(HOSTILE_TEXT)))
def test_a_hostile_spec_name_is_refused_or_exported_exactly(tmp_path, capsys, name) -> None:
    spec_file = tmp_path / "arm.yaml"
    spec_file.write_text(yaml.safe_dump({"name": name}, width=math.inf) + JOINTS)
    outcome = exported_or_refused(capsys, tmp_path, spec_file, "name")
    assert outcome == ("refused" if name in NOT_ONE_LINE else "same")
    if outcome == "same":
        assert mujoco.MjModel.from_xml_path(str(tmp_path / "arm.xml")).opt.gravity[2] == -9.81


HOSTILE_JOINT_NAMES = [
    "-->", "q1-->", "<!--", 'q"1', "q'1", "q&1", "q&amp;1", "q1\n", "q\n1", "q 1", "q\x001",
    "q\u202e1", "q1/lugre", '<include file="/etc/passwd"/>', "", "1q", "x" * 65, "ünï",
]


@pytest.mark.parametrize("name", HOSTILE_JOINT_NAMES, ids=range(len(HOSTILE_JOINT_NAMES)))
def test_a_hostile_joint_name_is_refused_in_one_line(tmp_path, capsys, name) -> None:
    spec_file = tmp_path / "arm.yaml"
    spec_file.write_text(f"name: arm\njoints:\n  - {{name: {json.dumps(name)}, type: R, "
                         "axis: z, body: {length: 1.0, mass: 2.0}}\n")
    status, _, err = cli(capsys, "export", spec_file, "-o", tmp_path / "arm.xml")
    assert status == 2 and not (tmp_path / "arm.xml").exists()
    assert_one_line(err, "arm.yaml:3", "field 'name'", "expected")


@pytest.mark.parametrize("names", [["a", "a_link"], ["a", "link_a"], ["q1", "Q1"],
                                   ["payload", "floor", "end_effector", "world", "base"],
                                   ["_", "_-", "__"], ["x" * 64, "y" * 64]],
                         ids=["suffix", "prefix", "case", "reserved", "punctuation", "longest"])
def test_names_that_could_collide_export_exactly(tmp_path, capsys, names) -> None:
    joints = "".join(f"  - {{name: {json.dumps(n)}, type: R, axis: {'zy'[i % 2]}, "
                     "body: {length: 0.5, mass: 1.0}, friction: {model: lugre, coulomb: 1.0}}\n"
                     for i, n in enumerate(names))
    spec_file = tmp_path / "arm.yaml"
    spec_file.write_text(f"name: arm\njoints:\n{joints}")
    assert exported_or_refused(capsys, tmp_path, spec_file, "name") == "same"


def test_a_hostile_file_name_stays_inside_the_comment(tmp_path, capsys) -> None:
    spec_file = tmp_path / 'x --> <option gravity="0 0 50"> <!-- y -.yaml'
    spec_file.write_text(f"name: arm\n{JOINTS}")
    assert exported_or_refused(capsys, tmp_path, spec_file, "name") == "same"
    assert mujoco.MjModel.from_xml_path(str(tmp_path / "arm.xml")).opt.gravity[2] == -9.81


# --- 8. numbers whose use overflows -------------------------------------------------------------

BODY = "body: {length: 1.0, mass: 2.0}"
HYDRAULIC = ("actuator: {type: hydraulic, area: 1.0e-3, volume: 1.0e-3, valve_gain: 1.0e-4, "
             "supply_pressure: 2.0e+7}")


def arm_text(joint: str = BODY, top: str = "") -> str:
    return f"name: arm\n{top}joints:\n  - {{name: q1, type: R, axis: y, {joint}}}\n"


@pytest.mark.parametrize(("text", "field", "words"), [
    (arm_text(top="gravity: [0, 0, -1.0e+308]\n"), "gravity[2]", ["beyond ±1e18"]),
    (arm_text(top="gravity: [0, 0, -1.0e+19]\n"), "gravity[2]", ["beyond ±1e18"]),
    (arm_text(top="gravity: [0, .nan, 0]\n"), "gravity[1]", ["finite"]),
    (arm_text(top="gravity: [0, 0, -.inf]\n"), "gravity[2]", ["finite"]),
    (arm_text("body: {length: 1.0, mass: 1.0e-320}"), "body.mass", ["below 1e-18"]),
    (arm_text("body: {length: 1.0, mass: 1.0e-300}"), "body.mass", ["below 1e-18"]),
    (arm_text("body: {length: 1.0, mass: 1.0e+300}"), "body.mass", ["beyond ±1e18"]),
    (arm_text("body: {length: 1.0e+200, mass: 1.0e+200}"), "body.length", ["beyond ±1e18"]),
    (arm_text("body: {length: 1.0, mass: 1, inertia: [1.0e+300, 1.0e+300, 1.0e+300, 0, 0, 0]}"),
     "body.inertia[0]", ["beyond ±1e18"]),
    (arm_text("body: {length: 1.0, mass: 1, com: [.nan, 0, 0]}"), "body.com[0]", ["finite"]),
    (arm_text(f"{BODY}, limits: [-1.0e+308, 1.0e+308]"), "limits[0]", ["beyond ±1e18"]),
    (arm_text(f"{BODY}, " + HYDRAULIC.replace("volume: 1.0e-3", "volume: 1.0e-300")),
     "actuator.volume", ["below 1e-18"]),
    (arm_text(f"{BODY}, " + HYDRAULIC.replace("area: 1.0e-3", "area: 5.0e-324")),
     "actuator.area", ["below 1e-18"]),
    (arm_text(f"{BODY}, " + HYDRAULIC.replace("}", ", bulk_modulus: 1.0e+300}")),
     "actuator.bulk_modulus", ["beyond ±1e18"]),
    (arm_text(f"{BODY}, " + HYDRAULIC.replace("}", ", leakage: .inf}")), "actuator.leakage",
     ["finite"]),
    (arm_text(f"{BODY}, actuator: {{type: torque, limit: 1.0e+300}}"), "actuator.limit",
     ["beyond ±1e18"]),
    (arm_text(f"{BODY}, friction: {{model: lugre, sigma0: 1.0e+300}}"), "friction.sigma0",
     ["beyond ±1e18"]),
    (arm_text(f"{BODY}, friction: {{model: hybrid, viscous: {10**400}}}"), "friction.viscous",
     ["finite"]),
    (arm_text(top="end_effector: {mass: 1.0e+308, offset: [0, 0, 0]}\n"), "end_effector.mass",
     ["beyond ±1e18"]),
    (arm_text(top="end_effector: {mass: 1.0e-320}\n"), "end_effector.mass", ["below 1e-18"]),
    (arm_text(top="end_effector: {offset: [1.0e+308, 0, 0]}\n"), "end_effector.offset[0]",
     ["beyond ±1e18"]),
], ids=range(21))
def test_numbers_whose_use_overflows_are_refused_naming_the_field(tmp_path, capsys, text, field,
                                                                    words) -> None:
    (tmp_path / "arm.yaml").write_text(text)
    status, _, err = cli(capsys, "validate", tmp_path / "arm.yaml")
    assert status == 2
    joint = [] if field.startswith(("gravity", "end_effector")) else ["joint q1"]
    assert_one_line(err, "arm.yaml:", *joint, f"field '{field}'", *words)


def test_the_bounds_themselves_give_a_finite_model(tmp_path, capsys) -> None:
    """Every number at ±1e18 or 1e-18 at once: the spec is valid and its MJCF holds no NaN.
    (The inertia is given: derived from these, m L²/12, it would be beyond the bounds, and a
    spec must read back what it writes.)"""
    text = arm_text(
        "body: {length: 1.0e+18, mass: 1.0e+18, inertia: [1.0e+18, 1.0e+18, 1.0e+18, 0, 0, 0]}, "
        "limits: [-1.0e+18, 1.0e+18], actuator: "
        "{type: hydraulic, area: 1.0e+18, volume: 1.0e-18, valve_gain: 1.0e-18, "
        "supply_pressure: 1.0e+18, bulk_modulus: 1.0e+18, valve_tau: 1.0e-18}",
        top="gravity: [0, 0, -1.0e+18]\nend_effector: {mass: 1.0e+18}\n")
    (tmp_path / "arm.yaml").write_text(text)
    status, _, err = cli(capsys, "export", tmp_path / "arm.yaml", "-o", tmp_path / "arm.xml")
    assert status == 0, err
    xml = (tmp_path / "arm.xml").read_text().lower()
    assert "nan" not in xml and "inf" not in xml
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "arm.xml"))
    assert np.all(np.isfinite(model.body_inertia)) and model.opt.gravity[2] == -1e18


def test_negative_zero_reads_as_zero() -> None:
    spec = ml.ManipulatorSpec.from_dict({"gravity": [-0.0, 0.0, -9.81], "joints": [
        {"type": "R", "axis": "z", "body": {"length": 1.0, "mass": -0.0, "com": [-0.0, 0, 0]}}],
        "end_effector": {"mass": 1.0}})
    assert math.copysign(1.0, spec.gravity[0]) == 1.0
    assert math.copysign(1.0, spec.joints[0].body.mass) == 1.0
    assert math.copysign(1.0, spec.joints[0].body.com[0]) == 1.0


# --- 9. loading data runs no code ---------------------------------------------------------------

EVIL = '''\
"""Writes a marker when imported: the proof that something ran it."""
from pathlib import Path

import numpy as np

from maniplab.actuators import ActuatorPlugin, parameters
from maniplab.schema import Positive

Path(__file__).with_name("RAN-" + __name__).write_text("imported")


class Spring(ActuatorPlugin):
    """Torque k (u - q)."""

    @parameters
    class Params:
        stiffness: Positive

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        return self.params.stiffness * (u - q)
'''


def evil_folder(tmp_path: Path, module: str = "evil") -> Path:
    """A folder with a module that marks its import, and a spec naming ``module:Spring``."""
    (tmp_path / f"{module}.py").write_text(EVIL)
    (tmp_path / "spec.yaml").write_text(arm_text(
        f"{BODY}, actuator: {{type: '{module}:Spring', stiffness: 5.0}}"))
    return tmp_path


def test_a_spec_naming_this_imports_nothing(tmp_path) -> None:
    (tmp_path / "spec.yaml").write_text(arm_text(f"{BODY}, actuator: {{type: 'this:s'}}"))
    result = child("validate", "spec.yaml", cwd=tmp_path)
    assert result.returncode == 2 and "Beautiful is better" not in result.stdout
    assert_one_line(result.stderr, "joint q1, field 'actuator.type'",
                    "'this:s' names module 'this', which was not loaded",
                    "name it with --plugin this or MANIPLAB_PLUGINS=this")


@pytest.mark.parametrize("module", ["evil", "yaml", "numpy"])
def test_python_m_maniplab_does_not_run_modules_of_the_current_folder(tmp_path, module) -> None:
    """Not the spec's plugin, and not a module that shadows one maniplab imports."""
    folder = evil_folder(tmp_path, module)
    result = child("validate", "spec.yaml", cwd=folder, module=True)
    assert not list(folder.glob("RAN-*"))
    assert result.returncode == 2
    assert_one_line(result.stderr, f"'{module}:Spring'" if module == "evil" else "Spring")


@pytest.mark.parametrize("how", ["--plugin", "MANIPLAB_PLUGINS"])
def test_a_module_named_on_purpose_is_loaded(tmp_path, how) -> None:
    folder = evil_folder(tmp_path)
    env = {"PYTHONPATH": str(folder)}
    extra: list[str] = []
    if how == "--plugin":
        extra = ["--plugin", "evil"]
    else:
        env[how] = "evil"
    result = child("validate", "spec.yaml", *extra, cwd=folder, env=env)
    assert result.returncode == 0, result.stderr
    assert (folder / "RAN-evil").exists() and "ok: arm is valid" in result.stdout


def test_a_plugin_option_that_cannot_be_imported_is_one_line(tmp_path, capsys) -> None:
    (tmp_path / "spec.yaml").write_text(arm_text())
    with pytest.raises(SystemExit) as caught:
        main(["validate", str(tmp_path / "spec.yaml"), "--plugin", "no_such_module_x"])
    assert caught.value.code == 2
    assert_one_line(capsys.readouterr().err, "--plugin: cannot import plugin module "
                    "'no_such_module_x'")


@pytest.fixture
def evil_run(tmp_path, monkeypatch) -> Path:
    """A run file whose stored spec names ``evilrun:Spring``, written with the module loaded on
    purpose; afterwards this process forgets the module, as a fresh one would not know it."""
    evil_folder(tmp_path, "evilrun")
    monkeypatch.delitem(sys.modules, "evilrun", raising=False)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(registry, "_LOADED", set())
    monkeypatch.setattr(registry, "_RESOLVED", {})
    ml.load_plugins("evilrun")
    spec = ml.load_spec(tmp_path / "spec.yaml")
    ml.simulate(spec, inputs={"q1": 0.1}, duration=0.01).save(tmp_path / "runs" / "a.npz")
    ml.simulate(spec.with_overrides({"joints.q1.body.mass": 3.0}), inputs={"q1": 0.1},
                duration=0.01).save(tmp_path / "runs" / "b.npz")
    del sys.modules["evilrun"]
    monkeypatch.setattr(registry, "_LOADED", set())
    monkeypatch.setattr(registry, "_RESOLVED", {})
    (tmp_path / "RAN-evilrun").unlink()
    return tmp_path


def test_loading_a_run_keeps_an_unavailable_plugin_unresolved(evil_run) -> None:
    run = ml.Run.load(evil_run / "runs" / "a.npz")
    actuator = run.spec.joints[0].actuator
    assert isinstance(actuator, UnresolvedActuator) and actuator.type == "evilrun:Spring"
    assert run.spec.to_dict()["joints"][0]["actuator"] == {"type": "evilrun:Spring",
                                                           "stiffness": 5.0}
    assert run.q.shape[1] == 1 and "evilrun" not in sys.modules
    with pytest.raises(ml.actuators.PluginLookupError, match="--plugin evilrun"):
        ml.spec.model_of(run.spec.joints[0])
    assert not (evil_run / "RAN-evilrun").exists()


def test_listing_runs_imports_no_plugin(evil_run) -> None:
    result = child("runs", "runs", cwd=evil_run, env={"PYTHONPATH": str(evil_run)})
    assert result.returncode == 0, result.stderr
    assert "a.npz" in result.stdout and "b.npz" in result.stdout
    assert not (evil_run / "RAN-evilrun").exists()


def test_comparing_runs_imports_no_plugin(evil_run) -> None:
    """A comparison is of stored data: it works without the runs' plugin (their command limits
    and state bounds, unknown then, go unchecked in the health lines) and never imports it."""
    args = ["compare", "runs/a.npz", "runs/b.npz", "-o", "cmp.png"]
    env = {"PYTHONPATH": str(evil_run), "MPLBACKEND": "Agg"}
    result = child(*args, cwd=evil_run, env=env)
    assert result.returncode == 0, result.stderr
    assert (evil_run / "cmp.png").stat().st_size > 0
    assert not (evil_run / "RAN-evilrun").exists()


def test_a_run_with_its_plugin_named_resolves_it(evil_run) -> None:
    ml.load_plugins("evilrun")
    run = ml.Run.load(evil_run / "runs" / "a.npz")
    assert run.spec.joints[0].actuator.stiffness == 5.0
    assert type(ml.spec.model_of(run.spec.joints[0])).__name__ == "Spring"
