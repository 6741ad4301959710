"""The maniplab command: sub-commands work on files and built-in names; bad input exits 2 with one
line on stderr and no traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from commandline import run_cli as run

from maniplab.cli import main

GOOD = """\
name: arm
joints:
  - {type: R, axis: z, body: {length: 1.0, mass: 2.0}}
  - {type: Tr, axis: x, limits: [0.0, 0.5], body: {length: 0.5, mass: 1.0}}
end_effector: {mass: 3.0}
"""


@pytest.fixture
def good_file(tmp_path: Path) -> Path:
    path = tmp_path / "arm.yaml"
    path.write_text(GOOD)
    return path


def test_version_matches_package_metadata() -> None:
    from importlib.metadata import version

    result = subprocess.run([sys.executable, "-m", "maniplab", "--version"],
                            capture_output=True, text=True, check=True)
    assert result.stdout.strip() == f"maniplab {version('maniplab')}"


@pytest.mark.parametrize("name", ["erector", "planar2", "crane3"])
def test_info_accepts_builtin_names(capsys: pytest.CaptureFixture[str], name: str) -> None:
    code, out, _ = run(capsys, "info", name)
    assert code == 0
    assert out.startswith(f"{name}: ")


def test_info_table_lists_every_joint_with_its_mass(capsys, good_file: Path) -> None:
    code, out, _ = run(capsys, "info", str(good_file))
    assert code == 0
    rows = [line.split() for line in out.splitlines() if line.startswith(("q1 ", "q2 "))]
    assert [r[0] for r in rows] == ["q1", "q2"]
    assert rows[1][1] == "P"  # the paper's Tr is shown as prismatic
    assert "total moving mass: 6 kg" in out


def test_info_list_names_the_builtins(capsys) -> None:
    code, out, _ = run(capsys, "info", "--list")
    assert code == 0 and all(n in out for n in ("erector", "planar2", "crane3"))


def test_export_writes_mjcf_that_mujoco_loads(capsys, good_file: Path, tmp_path: Path) -> None:
    target = tmp_path / "sub" / "arm.xml"
    code, out, _ = run(capsys, "export", str(good_file), "-o", str(target))
    assert code == 0 and str(target) in out
    model = mujoco.MjModel.from_xml_path(str(target))
    assert model.njnt == 2
    assert np.isclose(model.body_mass.sum(), 2.0 + 1.0 + 3.0)
    assert not list(target.parent.glob("*.tmp"))


def test_validate_reports_ok(capsys, good_file: Path) -> None:
    code, out, _ = run(capsys, "validate", str(good_file))
    assert code == 0 and out.startswith("ok: arm is valid (2 joints")


BAD_INPUTS = {
    "missing file": ("validate", "no/such/arm.yaml"),
    "unknown builtin": ("info", "erectorr"),
    "missing -o": ("export", "planar2"),
    "unknown command": ("frobnicate",),
    "unknown option": ("info", "planar2", "--colour"),
}


def exit_code(argv: tuple[str, ...]) -> int:
    """main()'s status, whether it returns it or argparse raises SystemExit."""
    try:
        return main(list(argv))
    except SystemExit as exc:
        return int(exc.code or 0)


@pytest.mark.parametrize("argv", BAD_INPUTS.values(), ids=BAD_INPUTS.keys())
def test_bad_arguments_exit_2_with_one_line(capsys, argv: tuple[str, ...]) -> None:
    code = exit_code(argv)
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


@pytest.mark.parametrize(
    ("text", "words"),
    [
        (GOOD.replace("mass: 2.0", "mass: -2.0"), ["arm.yaml:3", "joint q1", "body.mass", ">= 0"]),
        (GOOD.replace("axis: x", "axis: w"), ["joint q2", "axis", "'w'", "'x', 'y' or 'z'"]),
        (GOOD.replace("[0.0, 0.5]", "[0.5, 0.0]"), ["joint q2", "limits", "not increasing"]),
        (GOOD.replace("joints:", "joints: [").replace("end_effector", "]\nend_effector"),
         ["arm.yaml:", "invalid YAML"]),
    ],
    ids=["negative mass", "unknown axis", "reversed limits", "yaml syntax"],
)
def test_bad_spec_file_exits_2_naming_file_joint_field(
    tmp_path: Path, text: str, words: list[str]
) -> None:
    path = tmp_path / "arm.yaml"
    path.write_text(text)
    for command in (["validate"], ["info"], ["export", "-o", str(tmp_path / "x.xml")]):
        result = subprocess.run([sys.executable, "-m", "maniplab", *command[:1], str(path),
                                 *command[1:]], capture_output=True, text=True, check=False)
        assert result.returncode == 2, result.stderr
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in result.stderr
        for word in words:
            assert word in lines[0]
    assert not (tmp_path / "x.xml").exists()


def test_export_keeps_existing_file_when_spec_is_bad(tmp_path: Path, capsys) -> None:
    target = tmp_path / "arm.xml"
    target.write_text("previous")
    bad = tmp_path / "bad.yaml"
    bad.write_text("joints: []\n")
    assert main(["export", str(bad), "-o", str(target)]) == 2
    assert target.read_text() == "previous"
