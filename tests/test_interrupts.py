"""Long jobs answer Ctrl-C, and pool workers die with their parent.

Each job runs as ``python -m maniplab ...`` in a session of its own, with a terminal (a pty) as
stderr so that it draws its progress bars; once it is in the phase under test (its bar is drawn,
or its ffmpeg or compiler child runs), the test sends SIGINT to its process group, as a terminal
does on Ctrl-C. The job must end within ``ANSWER_S`` with status 130, "maniplab <cmd>:
interrupted" as the last line on stderr and nothing else alarming there, no output file, no
temporary file and no child process left.
"""

from __future__ import annotations

import fcntl
import os
import pty
import re
import signal
import struct
import subprocess
import sys
import termios
import textwrap
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import maniplab as ml

ANSWER_S = 10.0
"""Bound on the time from SIGINT to the job's exit, s (the requirement is 2 s; unfixed: minutes)."""

PHASE_S = 120.0
"""Bound on the time a job takes to reach the phase under test, s."""


# --- processes -----------------------------------------------------------------------------------

def _parents() -> dict[int, int]:
    """pid -> parent pid of every process (from /proc)."""
    out = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:
            continue  # ended meanwhile
        out[int(stat.parent.name)] = int(text[text.rindex(")") + 2:].split()[1])
    return out


def descendants(pid: int) -> list[int]:
    """The pids of every process below ``pid``."""
    children: dict[int, list[int]] = {}
    for child, parent in _parents().items():
        children.setdefault(parent, []).append(child)
    found, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie has ended)."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return text[text.rindex(")") + 2] != "Z"


def until(condition: Callable[[], bool], timeout: float, what: str) -> None:
    """Poll ``condition`` until it holds; fail after ``timeout`` seconds."""
    end = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < end, f"not within {timeout:g} s: {what}"
        time.sleep(0.02)


# --- a job in its own session ----------------------------------------------------------------------

class Job:
    """``python ARGV...`` in a new session, stderr on a pty, stdout on a pipe, both read in threads.

    Args:
        argv: the arguments after ``python``.
        env: more environment variables.
    """

    def __init__(self, argv: list[str], env: dict[str, str] | None = None) -> None:
        master, slave = pty.openpty()
        # a terminal of 24 x 120 characters (a new pty has 0 columns: progress bars draw nothing)
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 120, 0, 0))
        self.proc = subprocess.Popen([sys.executable, *argv], stdin=subprocess.DEVNULL,
                                     stdout=subprocess.PIPE, stderr=slave, start_new_session=True,
                                     env={**os.environ, **(env or {})})
        os.close(slave)
        self._err: list[bytes] = []
        self._out: list[bytes] = []
        assert self.proc.stdout is not None
        stdout_fd = self.proc.stdout.fileno()
        self.readers = [threading.Thread(target=_drain, args=(fd, chunks), daemon=True)
                        for fd, chunks in ((master, self._err), (stdout_fd, self._out))]
        for reader in self.readers:
            reader.start()
        self.master = master

    @property
    def stderr(self) -> str:
        return b"".join(self._err).decode(errors="replace")

    @property
    def stdout(self) -> str:
        return b"".join(self._out).decode(errors="replace")

    def wait_for(self, condition: Callable[[], bool], what: str) -> None:
        """Wait until the job is in its phase under test (and still running)."""
        until(lambda: condition() or self.proc.poll() is not None, PHASE_S, what)
        assert self.proc.poll() is None, f"ended before {what}:\n{self.stderr}"

    def child(self, text: str) -> bool:
        """Whether a process below the job has ``text`` in its command line."""
        return any(text in cmdline(pid) for pid in descendants(self.proc.pid))

    def interrupt(self, group: bool = True) -> tuple[float, list[int]]:
        """Ctrl-C: SIGINT to the job's process group (or to the job alone, as ``kill -INT``
        does); returns the seconds until it ended and the processes that were below it."""
        below = descendants(self.proc.pid)
        began = time.monotonic()
        if group:
            os.killpg(self.proc.pid, signal.SIGINT)
        else:
            os.kill(self.proc.pid, signal.SIGINT)
        try:
            self.proc.wait(timeout=ANSWER_S)
        except subprocess.TimeoutExpired:
            self.kill()
            raise AssertionError(f"no answer to SIGINT within {ANSWER_S:g} s:\n{self.stderr}")
        elapsed = time.monotonic() - began
        for reader in self.readers:
            reader.join(timeout=5)
        os.close(self.master)
        return elapsed, below

    def kill(self) -> None:
        """End the job's whole group (cleanup of a failed test)."""
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()


def _drain(fd: int, chunks: list[bytes]) -> None:
    while True:
        try:
            data = os.read(fd, 65536)
        except OSError:  # a pty reports the end of its last writer as EIO
            return
        if not data:
            return
        chunks.append(data)


@pytest.fixture
def job() -> Iterator[Callable[..., Job]]:
    """Start ``Job``s; any still running at the end of the test is killed."""
    jobs: list[Job] = []

    def start(argv: list[str], env: dict[str, str] | None = None) -> Job:
        jobs.append(Job(argv, env))
        return jobs[-1]

    yield start
    for j in jobs:
        j.kill()


def assert_interrupted(job: Job, command: str, output: Path) -> None:
    """Ctrl-C now; the job must end as an interrupted ``maniplab <command>`` and leave nothing."""
    elapsed, below = job.interrupt()
    err = job.stderr
    lines = [line.strip() for line in re.split(r"[\r\n]+", err) if line.strip()]
    assert job.proc.returncode == 130, err
    assert lines and lines[-1] == f"maniplab {command}: interrupted", err
    assert "Traceback" not in err and "Exception ignored" not in err, err
    assert elapsed < ANSWER_S
    assert not output.exists(), sorted(output.rglob("*")) if output.is_dir() else output
    assert not list(output.parent.glob(".*tmp*")), sorted(output.parent.iterdir())
    until(lambda: not any(alive(pid) for pid in below), 5.0,
          f"children end: {[cmdline(pid) for pid in below if alive(pid)]}")


def maniplab(*args: str) -> list[str]:
    return ["-m", "maniplab", *args]


# --- Ctrl-C ----------------------------------------------------------------------------------------

def test_simulate_answers_ctrl_c(job, tmp_path: Path) -> None:
    output = tmp_path / "run.npz"
    j = job(maniplab("simulate", "erector", "--duration", "100", "--dt", "1e-4", "-o", str(output)))
    j.wait_for(lambda: "simulating erector" in j.stderr, "the simulation runs")
    assert_interrupted(j, "simulate", output)


def test_a_streamed_simulate_answers_ctrl_c_and_leaves_no_file(job, tmp_path: Path) -> None:
    output = tmp_path / "run.npz"
    j = job(maniplab("simulate", "erector", "--duration", "100", "--dt", "1e-4", "--stream",
                     "-o", str(output)))
    j.wait_for(lambda: "simulating erector" in j.stderr, "the simulation runs")
    assert_interrupted(j, "simulate", output)


def test_a_sweep_in_threads_answers_ctrl_c(job, tmp_path: Path) -> None:
    """The variants run in threads, which the signal does not reach; they stop at their pause."""
    output = tmp_path / "sweep"
    j = job(maniplab("sweep", "erector", "--vary", "end_effector.mass=3000,4000,5000",
                     "--duration", "100", "--dt", "1e-4", "--processes", "2", "-o", str(output)))
    j.wait_for(lambda: "sweep erector" in j.stderr, "the sweep runs")
    assert_interrupted(j, "sweep", output)


SWEEP_SCRIPT = """
import sys
import numpy as np
import maniplab as ml

class Idle:
    \"\"\"A controller that commands nothing: it makes the sweep run its variants in processes.\"\"\"
    def __call__(self, t, state):
        return np.zeros(len(state.q))

try:
    ml.sweep("planar2", {"end_effector.mass": [1.0, 2.0]}, out=sys.argv[1], duration=1e4,
             controller=Idle(), processes=2, progress=False)
except KeyboardInterrupt:
    sys.exit(130)
"""


def sweep_in_processes(job, tmp_path: Path) -> tuple[Job, list[int]]:
    """A sweep whose two variants run for hours in worker processes; the job and its workers."""
    script = tmp_path / "sweep.py"
    script.write_text(textwrap.dedent(SWEEP_SCRIPT))
    j = job([str(script), str(tmp_path / "sweep")])

    def workers() -> list[int]:  # forked: the parent's command line (not its resource tracker)
        return [pid for pid in descendants(j.proc.pid) if cmdline(pid) == cmdline(j.proc.pid)]

    j.wait_for(lambda: len(workers()) == 2, "the workers run")
    return j, workers()


def test_a_sweep_in_processes_answers_ctrl_c_without_worker_noise(job, tmp_path: Path) -> None:
    j, workers = sweep_in_processes(job, tmp_path)
    elapsed, below = j.interrupt()
    assert j.proc.returncode == 130 and elapsed < ANSWER_S, j.stderr
    assert "Traceback" not in j.stderr and "Exception ignored" not in j.stderr, j.stderr
    assert not any(alive(pid) for pid in workers)  # stopped and reaped before the sweep returned
    assert not (tmp_path / "sweep").exists()
    until(lambda: not any(alive(pid) for pid in below), 5.0, "the resource tracker ends")


def test_render_answers_ctrl_c_while_ffmpeg_encodes(job, tmp_path: Path) -> None:
    """ffmpeg must neither die of the terminal's SIGINT (a write error instead of the interrupt)
    nor outlive the job."""
    run = tmp_path / "run.npz"
    ml.simulate("planar2", duration=60.0, sample_dt=0.01).save(run)
    output = tmp_path / "video" / "run.mp4"
    j = job(maniplab("render", str(run), "--width", "320", "--height", "180", "-o", str(output)))
    j.wait_for(lambda: any(p.stat().st_size for p in output.parent.glob(".*tmp*")),
               "ffmpeg encodes")
    assert_interrupted(j, "render", output)


def big_arm(path: Path, n: int) -> Path:
    """An n-joint arm of tilted links with full inertia: C files that take a while to compile
    (n = 20: about 10 s on 2 cores)."""
    joints = "".join(
        f"  - {{type: R, axis: {'xyz'[k % 3]}, body: {{length: 0.5, mass: 10.0, "
        f"direction: {[0.6, 0.0, 0.8] if k % 2 else [0.0, 0.8, 0.6]}, com: [0.1, 0.05, 0.02], "
        f"inertia: [1.0, 1.2, 1.4, 0.1, 0.05, 0.02]}}}}\n" for k in range(n))
    path.write_text(f"name: big{n}\njoints:\n{joints}")
    return path


def test_crossval_answers_ctrl_c_while_the_model_compiles(job, tmp_path: Path) -> None:
    """A cold model cache: the C compiler (and its cc1) must be killed, no cache entry made and
    no half-built staging folder left."""
    cache = tmp_path / "cache"
    output = tmp_path / "crossval.png"
    arm = big_arm(tmp_path / "big.yaml", 20)
    j = job(maniplab("crossval", str(arm), "--duration", "0.1", "-o", str(output)),
            env={"MANIPLAB_CACHE": str(cache)})
    j.wait_for(lambda: j.child("C.c"), "the compiler of the model's C kernel runs")
    assert_interrupted(j, "crossval", output)
    assert {p.name for p in cache.iterdir()} <= {"plugins", "steps"}  # no model entry


def test_crossval_answers_ctrl_c_while_scipy_integrates(job, tmp_path: Path) -> None:
    output = tmp_path / "crossval.png"
    j = job(maniplab("crossval", "erector", "--duration", "100", "-o", str(output)))
    j.wait_for(lambda: "scipy DOP853 on the analytic model" in j.stderr, "scipy integrates")
    assert_interrupted(j, "crossval", output)


def test_demo_answers_ctrl_c_and_leaves_no_folder(job, tmp_path: Path) -> None:
    output = tmp_path / "demo"
    j = job(maniplab("demo", "--quick", "-o", str(output)))
    j.wait_for(lambda: "open-loop responses" in j.stdout, "the demo's sweeps run")
    assert_interrupted(j, "demo", output)


BUILD_SCRIPT = """
import sys
from maniplab_native.build import library_path

try:
    library_path()
except KeyboardInterrupt:
    sys.exit(130)
"""


@pytest.mark.parametrize("group", [True, False], ids=["terminal", "kill"])
def test_the_native_library_build_answers_ctrl_c(job, tmp_path: Path, group: bool) -> None:
    """A compiler that takes long (here: sleeps before compiling) is killed with its children,
    and its half-written library removed, also when SIGINT reaches maniplab alone."""
    compiler = tmp_path / "slowcc"
    compiler.write_text('#!/bin/sh\nsleep 600\nexec cc "$@"\n')
    compiler.chmod(0o755)
    script = tmp_path / "build.py"
    script.write_text(textwrap.dedent(BUILD_SCRIPT))
    cache = tmp_path / "cache"
    j = job([str(script)], env={"MANIPLAB_CACHE": str(cache), "MANIPLAB_CC": str(compiler)})
    j.wait_for(lambda: j.child("sleep 600"), "the compiler runs")
    elapsed, below = j.interrupt(group)
    assert j.proc.returncode == 130 and elapsed < ANSWER_S, j.stderr
    assert not [p for p in cache.rglob("*") if p.is_file()]
    until(lambda: not any(alive(pid) for pid in below), 5.0, "the compiler ends")


# --- workers die with their parent -------------------------------------------------------------

def test_workers_die_when_their_parent_is_killed(job, tmp_path: Path) -> None:
    j, workers = sweep_in_processes(job, tmp_path)
    os.kill(j.proc.pid, signal.SIGKILL)
    until(lambda: not any(alive(pid) for pid in workers), 5.0, "the workers end")


ORPHAN_SCRIPT = """
import os, sys, time
from maniplab import workers

parent = int(sys.argv[1])
if sys.argv[2] == "poll":  # the fallback where prctl is missing
    workers._set_parent_death_signal = lambda: False
workers.die_with_parent(parent)
print("watching", flush=True)
time.sleep(600)
"""


@pytest.mark.parametrize("how", ["prctl", "poll"])
def test_a_worker_whose_parent_died_before_it_watched_ends_itself(tmp_path: Path, how: str) -> None:
    """The race: the parent is gone (the worker was re-parented) when the worker sets up."""
    script = tmp_path / "orphan.py"
    script.write_text(textwrap.dedent(ORPHAN_SCRIPT))
    not_my_parent = os.getpid() + 10**6  # no process has this pid as the script's parent
    proc = subprocess.run([sys.executable, str(script), str(not_my_parent), how],
                          capture_output=True, text=True, timeout=60, check=False)
    assert proc.returncode == -signal.SIGKILL and "watching" not in proc.stdout, proc.stderr


POLL_SCRIPT = """
import subprocess, sys
child = subprocess.Popen([sys.executable, "-c", '''
import os, sys, time
from maniplab import workers
workers._set_parent_death_signal = lambda: False
workers.die_with_parent(os.getppid())
print(os.getpid(), flush=True)
time.sleep(600)
'''], stdout=subprocess.PIPE, text=True)
print(child.stdout.readline().strip(), flush=True)
time.sleep(600)
"""


def test_the_polling_fallback_ends_a_worker_after_its_parent(tmp_path: Path) -> None:
    script = tmp_path / "parent.py"
    script.write_text("import time\n" + textwrap.dedent(POLL_SCRIPT))
    parent = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    try:
        assert parent.stdout is not None
        worker = int(parent.stdout.readline())
        assert alive(worker)
        parent.kill()
        parent.wait()
        until(lambda: not alive(worker), 5.0, "the worker ends")
    finally:
        parent.kill()
        parent.wait()
        if parent.stdout is not None:
            parent.stdout.close()


def test_the_console_script_answers_ctrl_c_while_maniplab_is_imported(job, tmp_path: Path) -> None:
    """On first use `import mujoco` builds maniplab's native plugins (here with a compiler that
    takes long): a Ctrl-C then is one line and status 130 too. (The package imports MuJoCo
    lazily, so the build happens once the command has started: the line names it.)"""
    compiler = tmp_path / "slowcc"
    compiler.write_text('#!/bin/sh\nsleep 600\nexec cc "$@"\n')
    compiler.chmod(0o755)
    script = Path(sys.executable).parent / "maniplab"  # the console script pip installed
    output = tmp_path / "arm.xml"
    j = job([str(script), "export", "erector", "-o", str(output)],
            env={"MANIPLAB_CACHE": str(tmp_path / "cache"), "MANIPLAB_CC": str(compiler)})
    j.wait_for(lambda: j.child("sleep 600"), "the native library builds during the import")
    elapsed, below = j.interrupt()
    lines = [line.strip() for line in j.stderr.splitlines() if line.strip()]
    assert j.proc.returncode == 130 and lines == ["maniplab export: interrupted"], j.stderr
    assert elapsed < ANSWER_S and not output.exists()
    until(lambda: not any(alive(pid) for pid in below), 5.0, "the compiler ends")


def test_work_in_c_code_is_waited_for_interruptibly() -> None:
    """interruptible() hands back the helper's value or error, and answers Ctrl-C while the
    helper is still busy (here: blocked on an event nobody sets, as symengine's cse is in C)."""
    from maniplab.workers import interruptible

    assert interruptible(sum, [1, 2, 3]) == 6
    with pytest.raises(ZeroDivisionError):
        interruptible(divmod, 1, 0)
    never = threading.Event()
    timer = threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        interruptible(never.wait)
    never.set()  # the helper ends too


def test_ctrl_c_inside_the_pools_own_code_is_taken_after_it() -> None:
    """A Ctrl-C that lands inside concurrent.futures (between a lock's acquisition and its
    release) could leave the pool's lock held and its shutdown waiting forever; submissions and
    waits therefore take it when they are done: the block runs to its end, then it is raised."""
    from maniplab.workers import Threads, interrupts_deferred

    ran: list[str] = []
    with pytest.raises(KeyboardInterrupt), interrupts_deferred():
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.05)  # the signal is handled between these bytecodes, and only noted
        ran.append("after the signal")
    assert ran == ["after the signal"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler

    pool = Threads(2)
    never = threading.Event()
    timer = threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    began = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        pool.map_results(never.wait, [(30.0,), (30.0,)])
    assert time.monotonic() - began < 2.0
    never.set()
    stopped = threading.Thread(target=pool.stop)
    stopped.start()
    stopped.join(timeout=5.0)
    assert not stopped.is_alive(), "the pool's shutdown hangs"
