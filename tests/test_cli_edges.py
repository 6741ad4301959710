"""Rough edges of the command line found by the safety audit: each exits with the status and the
one line a user should see."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from commandline import run_cli as run

import maniplab as ml
from maniplab.cli.common import EXIT_BAD_INPUT, EXIT_MISSED
from maniplab.control.errors import LinearizeError


@pytest.mark.parametrize("argv, command", [
    (["simulate", "crane3", "--duration", "0.1", "--bogus"], "simulate"),
    (["info", "erector", "extra"], "info"),
    (["sweep", "crane3", "--duration", "0.1", "--vary", "end_effector.mass=1", "-o", "x",
      "--procs", "2"], "sweep"),
])
def test_an_unknown_argument_points_to_the_sub_commands_help(
        capsys: pytest.CaptureFixture[str], argv: list[str], command: str) -> None:
    code, _, err = run(capsys, *argv)
    assert code == EXIT_BAD_INPUT
    assert err.count("\n") == 1 and "unrecognized arguments" in err
    assert f"see 'maniplab {command} --help'" in err


def test_an_unknown_argument_without_a_command_is_one_line(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "--bogus")
    assert code == EXIT_BAD_INPUT and out == ""
    assert err.strip() == "maniplab: error: unrecognized arguments: --bogus (see 'maniplab --help')"


@pytest.mark.parametrize("value", ["0", "-2", "two"])
def test_sweep_refuses_a_worker_count_below_one(capsys: pytest.CaptureFixture[str],
                                                tmp_path: Path, value: str) -> None:
    code, _, err = run(capsys, "sweep", "crane3", "--duration", "0.1", "--vary",
                       "end_effector.mass=1", "--processes", value, "-o", str(tmp_path / "s"))
    assert code == EXIT_BAD_INPUT
    assert "--processes" in err and err.count("\n") == 1
    assert not (tmp_path / "s").exists()


def test_a_sweep_with_a_failed_variant_exits_non_zero(capsys: pytest.CaptureFixture[str],
                                                      tmp_path: Path) -> None:
    """A payload of 1000 t on crane3 drives the luff's load pressure far past any bound: that
    variant fails, the other is stored, and the status says the job did not all succeed."""
    out_dir = tmp_path / "sweep"
    code, out, _ = run(capsys, "sweep", "crane3", "--duration", "0.3", "--dt", "0.01",
                       "--vary", "end_effector.mass=1,1e6", "--processes", "1",
                       "-o", str(out_dir))
    assert code == EXIT_MISSED
    assert "1 runs in" in out and "1 failed" in out
    failed = [line for line in out.splitlines() if line.startswith("FAILED")]
    assert len(failed) == 1 and "luff" in failed[0]
    assert len(ml.RunSet(out_dir)) == 1


def test_linearize_says_why_no_valve_current_holds_the_arm() -> None:
    """At 1000 t the luff's cylinder would need a load pressure far above its supply: the
    operating point has no valve current, and the error says so instead of returning inf."""
    spec = ml.builtin_spec("crane3").with_overrides({"end_effector.mass": 1e6})
    with pytest.raises(LinearizeError, match=r"joint luff: no command holds the arm.*supply "
                                             r"pressure") as info:
        ml.linearize(spec, np.zeros(spec.n))
    assert "\n" not in str(info.value)


def test_linearize_at_a_feasible_point_still_works() -> None:
    spec = ml.builtin_spec("crane3")
    sys = ml.linearize(spec, np.zeros(spec.n))
    assert np.isfinite(np.asarray(sys.A)).all()


@pytest.mark.parametrize("argv", [
    ["simulate", "crane3", "--duration", "5", "-o", "/dev/full"],
    ["crossval", "crane3", "-o", "/dev/null"],
    ["export", "crane3", "-o", "{tmp}"],
    ["sweep", "crane3", "--duration", "5", "--vary", "end_effector.mass=1,2", "-o", "{file}"],
    ["demo", "--quick", "-o", "{file}"],
])
def test_an_output_that_cannot_be_written_is_refused_before_any_work(
        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
        argv: list[str]) -> None:
    """A device, a folder given as -o FILE, a file given as -o DIR: one line at once, nothing
    simulated (ml.simulate, crossvalidate and sweep would raise here), nothing replaced."""
    def forbidden(*args: object, **kwargs: object) -> None:
        raise AssertionError("work started for an output that cannot be written")

    for name in ("simulate", "crossvalidate", "sweep"):
        monkeypatch.setattr(ml, name, forbidden)
    (tmp_path / "file").write_text("mine")
    argv = [a.format(tmp=tmp_path, file=tmp_path / "file") for a in argv]
    code, out, err = run(capsys, *argv)
    assert code == EXIT_BAD_INPUT and out == ""
    assert err.count("\n") == 1 and "argument -o/--output" in err
    assert (tmp_path / "file").read_text() == "mine" and Path("/dev/full").is_char_device()
