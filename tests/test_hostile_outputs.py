"""Hostile outputs and run files: -o never replaces what is not a file, errors name the user's
path, leftover temporary files neither break listings nor pile up, corrupt runs are one line."""

from __future__ import annotations

import errno
import fcntl
import json
import os
import pickle
import signal
import stat
import subprocess
import sys
import time
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
from commandline import run_cli as cli

import maniplab as ml
from maniplab import atomic
from maniplab.sim import Run, RunFileError, store


def assert_one_line_error(code: int, err: str, *names: str) -> None:
    """Exit 2, one line on stderr naming every one of ``names``, nothing of numpy's or a
    temporary file's."""
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert all(name in err for name in names), err
    assert ".tmp" not in err and "Traceback" not in err and "allow_pickle" not in err, err


def small_run(mass: float = 4000.0) -> Run:
    """A short erector run (6 joints, 11 samples), made without simulating."""
    spec = ml.builtin_spec("erector").with_overrides({"end_effector.mass": mass})
    t = np.linspace(0.0, 0.1, 11)
    signals = {"q": np.full((11, spec.n), mass * 1e-4), "qd": np.zeros((11, spec.n))}
    return Run(t, signals, spec, {"label": f"m{mass:g}"})


# -- outputs that are not regular files ----------------------------------------------------------

COMMANDS: dict[str, Callable[[Path], list[str]]] = {
    "simulate": lambda out: ["simulate", "erector", "--duration", "0.02", "-o", str(out)],
    "export": lambda out: ["export", "erector", "-o", str(out)],
}


def fifo(tmp_path: Path) -> Path:
    os.mkfifo(tmp_path / "pipe")
    return tmp_path / "pipe"


def folder(tmp_path: Path) -> Path:
    (tmp_path / "dir.npz").mkdir()
    return tmp_path / "dir.npz"


TARGETS: dict[str, tuple[Callable[[Path], Path], Callable[[int], bool]]] = {
    "/dev/null": (lambda _: Path("/dev/null"), stat.S_ISCHR),
    "/dev/full": (lambda _: Path("/dev/full"), stat.S_ISCHR),
    "fifo": (fifo, stat.S_ISFIFO),
    "folder": (folder, stat.S_ISDIR),
}


@pytest.fixture(autouse=True)
def devices_restored() -> Iterator[None]:
    """Put /dev/null and /dev/full back should a regression replace them (we may be root): the
    rest of the machine needs them."""
    before = {path: os.stat(path) for path in ("/dev/null", "/dev/full")}
    yield
    for path, was in before.items():
        if not stat.S_ISCHR(os.stat(path).st_mode):
            os.mknod(f"{path}.restored", stat.S_IFCHR, was.st_rdev)
            os.chmod(f"{path}.restored", 0o666)  # mknod's mode is cut by the umask
            os.replace(f"{path}.restored", path)


@pytest.mark.parametrize("target", TARGETS)
@pytest.mark.parametrize("command", COMMANDS)
def test_an_output_that_is_not_a_file_is_refused_and_left_alone(
        capsys, tmp_path: Path, command: str, target: str) -> None:
    make, is_kind = TARGETS[target]
    path = make(tmp_path)
    code, _, err = cli(capsys, *COMMANDS[command](path))
    assert_one_line_error(code, err, str(path), "not a regular file")
    assert is_kind(os.stat(path).st_mode)
    assert not [p for p in path.parent.iterdir() if atomic.is_temporary(p)]


def test_compare_refuses_dev_null_as_its_figure(capsys, tmp_path: Path) -> None:
    small_run().save(tmp_path / "a.npz")
    code, _, err = cli(capsys, "compare", str(tmp_path / "a.npz"), "-o", "/dev/null")
    assert_one_line_error(code, err, "/dev/null")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_dev_stdout_on_a_pipe_is_refused() -> None:
    done = subprocess.run([sys.executable, "-m", "maniplab", "export", "erector", "-o",
                           "/dev/stdout"], capture_output=True, text=True, check=False)
    assert_one_line_error(done.returncode, done.stderr, "/dev/stdout: a fifo")
    assert done.stdout == ""


@pytest.mark.parametrize("command", COMMANDS)
def test_a_symlink_is_written_through(capsys, tmp_path: Path, command: str) -> None:
    real = tmp_path / "real" / f"file{'.npz' if command == 'simulate' else '.xml'}"
    real.parent.mkdir()
    real.write_text("old")
    middle = tmp_path / f"middle{real.suffix}"
    link = tmp_path / "links" / f"link{real.suffix}"
    link.parent.mkdir()
    middle.symlink_to(real)
    link.symlink_to(middle)  # a chain: link -> middle -> real
    code, _, err = cli(capsys, *COMMANDS[command](link))
    assert code == 0, err
    assert link.is_symlink() and middle.is_symlink() and os.readlink(link) == str(middle)
    assert real.read_bytes() != b"old" and real.stat().st_size > 100
    if command == "simulate":
        assert Run.load(link).spec.name == "erector"
    assert sorted(p.name for p in real.parent.iterdir()) == [real.name]  # no temporary left
    assert sorted(p.name for p in link.parent.iterdir()) == [link.name]


def test_a_dangling_symlink_is_written_where_it_points_if_that_folder_exists(
        capsys, tmp_path: Path) -> None:
    link = tmp_path / "link.xml"
    link.symlink_to(tmp_path / "new.xml")
    code, _, err = cli(capsys, "export", "erector", "-o", str(link))
    assert code == 0, err
    assert link.is_symlink() and (tmp_path / "new.xml").read_text().startswith("<mujoco")

    lost = tmp_path / "lost.xml"
    lost.symlink_to(tmp_path / "missing" / "new.xml")
    code, _, err = cli(capsys, "export", "erector", "-o", str(lost))
    assert_one_line_error(code, err, str(lost), "No such file or directory")
    assert not (tmp_path / "missing").exists() and lost.is_symlink()


# -- errors name the path the user gave ----------------------------------------------------------

def test_a_folder_that_is_a_file_is_named_as_given(capsys, tmp_path: Path) -> None:
    (tmp_path / "file").write_text("")
    target = tmp_path / "file" / "arm.xml"
    code, _, err = cli(capsys, "export", "erector", "-o", str(target))
    assert_one_line_error(code, err, str(target), "Not a directory")


def test_a_failed_rename_names_the_output_not_the_temporary(capsys, tmp_path: Path,
                                                           monkeypatch) -> None:
    target = tmp_path / "arm.xml"
    target.write_text("old")

    def read_only(src: str, dst: str) -> None:
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), src)

    monkeypatch.setattr(os, "replace", read_only)
    code, _, err = cli(capsys, "export", "erector", "-o", str(target))
    assert_one_line_error(code, err, str(target), "Read-only file system")
    assert target.read_text() == "old" and os.listdir(tmp_path) == ["arm.xml"]


WRITE_ERRORS: dict[str, tuple[Callable[[str], OSError], str]] = {
    "full disk": (lambda tmp: OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)),
                  "No space left on device"),
    "no errno": (lambda tmp: OSError(f"cannot write {tmp}"), "cannot write"),
}


@pytest.mark.parametrize("error", WRITE_ERRORS)
def test_an_error_while_writing_names_the_output(capsys, tmp_path: Path, monkeypatch,
                                                 error: str) -> None:
    make, words = WRITE_ERRORS[error]

    def failing(handle, *args: object, **kwargs: object) -> None:
        raise make(handle.name)

    monkeypatch.setattr(np, "savez", failing)
    target = tmp_path / "run.npz"
    code, _, err = cli(capsys, *COMMANDS["simulate"](target))
    assert_one_line_error(code, err, str(target), words)
    assert os.listdir(tmp_path) == []


# -- leftover temporary files --------------------------------------------------------------------

def stale(path: Path) -> Path:
    """``path`` with garbage, last changed twice the staleness bound ago."""
    path.write_bytes(b"PK\x03\x04 half a run")
    past = time.time() - 2 * atomic.STALE_AFTER
    os.utime(path, (past, past))
    return path


@pytest.fixture
def runs_dir(tmp_path: Path) -> Path:
    """Two good runs, a.npz and b.npz, and the stale temporary file of a killed save of run.npz."""
    folder = tmp_path / "runs"
    small_run(3000.0).save(folder / "a.npz")
    small_run(5000.0).save(folder / "b.npz")
    stale(folder / ".run.k1ll3d00.tmp.npz")
    return folder


def test_listings_skip_leftover_temporaries_and_what_is_not_a_file(capsys,
                                                                   runs_dir: Path) -> None:
    (runs_dir / "folder.npz").mkdir()
    os.mkfifo(runs_dir / "pipe.npz")  # reading it would block
    code, out, err = cli(capsys, "runs", str(runs_dir))
    assert code == 0, err
    assert [line.split()[0] for line in out.splitlines()[2:]] == ["a.npz", "b.npz"]
    assert ".tmp" not in out
    runs = ml.RunSet(runs_dir)
    assert [p.name for p in runs.paths] == ["a.npz", "b.npz"]
    assert [run.label for run in runs] == ["m3000", "m5000"]
    with pytest.raises(RunFileError, match="pipe.npz: not a regular file"):
        Run.load(runs_dir / "pipe.npz")


def test_the_next_save_removes_stale_temporaries_only(capsys, runs_dir: Path) -> None:
    young = runs_dir / ".run.y0ung000.tmp.npz"
    young.write_bytes(b"a save in progress")
    other = stale(runs_dir / ".other.0ld00000.tmp.npz")  # another target's: not this save's
    locked = stale(runs_dir / ".run.l0cked00.tmp.npz")
    users = stale(runs_dir / ".run.backup.tmp.npz")  # the user's own file: not a mkstemp name
    with open(locked, "rb") as held:
        fcntl.flock(held, fcntl.LOCK_EX)  # a live writer, however old its file
        code, _, err = cli(capsys, *COMMANDS["simulate"](runs_dir / "run.npz"))
    assert code == 0, err
    assert not (runs_dir / ".run.k1ll3d00.tmp.npz").exists()
    assert young.exists() and other.exists() and locked.exists() and users.exists()
    assert Run.load(runs_dir / "run.npz").spec.name == "erector"


WRITER = """
import sys, time
from maniplab.atomic import atomic_path
with atomic_path(sys.argv[1]) as tmp:
    tmp.write_bytes(b"half a run")
    print(tmp, flush=True)
    time.sleep(60)
"""


@pytest.fixture
def writer_mid_save(tmp_path: Path) -> Iterator[tuple[subprocess.Popen[str], Path]]:
    """A process in the middle of saving tmp_path/run.npz, and its temporary file."""
    writer = subprocess.Popen([sys.executable, "-c", WRITER, str(tmp_path / "run.npz")],
                              stdout=subprocess.PIPE, text=True)
    assert writer.stdout is not None
    yield writer, Path(writer.stdout.readline().strip())
    writer.kill()
    writer.wait()


def test_a_live_writer_keeps_its_file_and_a_killed_one_is_cleaned_up(
        writer_mid_save: tuple[subprocess.Popen[str], Path], tmp_path: Path) -> None:
    writer, tmp = writer_mid_save
    past = time.time() - 2 * atomic.STALE_AFTER
    os.utime(tmp, (past, past))  # old, but its writer is alive and holds the lock
    small_run().save(tmp_path / "run.npz")
    assert tmp.read_bytes() == b"half a run"

    os.kill(writer.pid, signal.SIGKILL)
    writer.wait()
    assert len(ml.RunSet(tmp_path)) == 1  # the leftover is not listed
    small_run().save(tmp_path / "run.npz")
    assert os.listdir(tmp_path) == ["run.npz"]


# -- corrupt and inconsistent run files ----------------------------------------------------------

def rewrite(path: Path, t: np.ndarray | None = None, edit: Callable[[dict], None] = lambda h: None,
            rehash: bool = True) -> None:
    """Write ``path`` again as a run file with ``t`` and an edited header, the hash made to fit
    (a hand-crafted file, not a corrupt one) unless not ``rehash``."""
    run = small_run()
    header = store.header_of(run)
    edit(header)
    t = run.t if t is None else t
    if rehash:
        header["hash"] = store.content_hash(t, dict(run.signals), header)
    np.savez(path, t=t, header=np.array(json.dumps(header)),
             **{f"signal/{k}": v for k, v in run.signals.items()})


def truncated(path: Path) -> None:
    path.write_bytes(path.read_bytes()[:300])


def pickled_member(path: Path) -> None:
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("header.npy", pickle.dumps({"format": store.FORMAT}))
        archive.writestr("t.npy", pickle.dumps([0.0, 1.0]))


def bad_spec(header: dict) -> None:
    header["spec"]["joints"] = "none"


def wrong_format(header: dict) -> None:
    header["format"] = "maniplab-run/99"


# name -> (how to spoil a good run file, found from the header alone, words of the message)
CORRUPTIONS: dict[str, tuple[Callable[[Path], None], bool, str]] = {
    "truncated": (truncated, True, "not a readable maniplab run file"),
    "zero bytes": (lambda p: p.write_bytes(b""), True, "not an .npz archive"),
    "text file": (lambda p: p.write_text("q,t\n1,2\n"), True, "not an .npz archive"),
    "foreign npz": (lambda p: np.savez(p, x=np.arange(3)), True, "no 'header' array"),
    "object array": (lambda p: np.savez(p, header=np.array([{"a": 1}], dtype=object)), True,
                     "'header'"),
    "pickled member": (pickled_member, True, "'header'"),
    "wrong format": (lambda p: rewrite(p, edit=wrong_format), True, "unknown run format"),
    "invalid spec": (lambda p: rewrite(p, edit=bad_spec), True, "the stored spec is invalid"),
    "hash mismatch": (lambda p: rewrite(p, t=np.linspace(0, 1, 11), rehash=False), False,
                      "content hash mismatch"),
    "short t": (lambda p: rewrite(p, t=np.linspace(0, 0.1, 5)), False,
                "signal 'q' has 11 samples, t has 5"),
    "times not increasing": (lambda p: rewrite(p, t=np.zeros(11)), False, "increasing"),
}


@pytest.fixture(params=CORRUPTIONS)
def corrupt(request, tmp_path: Path) -> tuple[Path, bool, str]:
    """A folder holding good.npz and a spoiled bad.npz; the bad file, whether its header shows
    it, and the words its error must contain."""
    spoil, in_header, words = CORRUPTIONS[request.param]
    small_run().save(tmp_path / "good.npz")
    bad = tmp_path / "bad.npz"
    small_run().save(bad)
    spoil(bad)
    return bad, in_header, words


def test_a_corrupt_run_is_one_line_naming_the_file(capsys, corrupt: tuple[Path, bool, str],
                                                   tmp_path: Path) -> None:
    bad, in_header, words = corrupt
    good = str(tmp_path / "good.npz")
    for argv in (["compare", good, str(bad), "-o", str(tmp_path / "c.png")],
                 ["render", str(bad), "-o", str(tmp_path / "v.mp4")]):
        code, _, err = cli(capsys, *argv)
        assert_one_line_error(code, err, str(bad), words)
    with pytest.raises(RunFileError, match=words) as caught:
        Run.load(bad)
    assert str(bad) in str(caught.value) and "trust" not in str(caught.value)
    assert not (tmp_path / "c.png").exists() and not (tmp_path / "v.mp4").exists()

    code, out, err = cli(capsys, "runs", str(tmp_path))
    if in_header:
        assert_one_line_error(code, err, str(bad), words)
    else:  # `runs` reads headers only; the content is checked when a run is loaded
        assert code == 0 and "bad.npz" in out, err


def test_a_replaced_file_keeps_its_permissions(capsys, tmp_path: Path) -> None:
    """A private 0600 file stays private when maniplab writes it again; a new one gets 0666 less
    the umask (not mkstemp's 0600)."""
    private = tmp_path / "arm.xml"
    private.write_text("old")
    private.chmod(0o600)
    code, _, err = cli(capsys, "export", "erector", "-o", str(private))
    assert code == 0, err
    assert stat.S_IMODE(private.stat().st_mode) == 0o600 and "<mujoco" in private.read_text()
    fresh = tmp_path / "new.xml"
    mask = os.umask(0o022)
    try:
        assert cli(capsys, "export", "erector", "-o", str(fresh))[0] == 0
    finally:
        os.umask(mask)
    assert stat.S_IMODE(fresh.stat().st_mode) == 0o644
