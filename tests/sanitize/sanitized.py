"""What the fuzzing of ``tests/sanitize/`` shares: the sanitized environment, the hypothesis
settings, the arms, and running code in a sanitized child process.

maniplab's native library (and an FMU's C functions) built with ``MANIPLAB_NATIVE_SANITIZE=1``
links AddressSanitizer and UBSan, which must be the process's first library: Python is started
with ``LD_PRELOAD`` of libasan. ``detect_leaks=0``: CPython frees little at exit, and LeakSanitizer
would report it. Any ASan or UBSan report aborts the process (``halt_on_error``,
``-fno-sanitize-recover``), so a finding is a non-zero exit with the report on stderr.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent

ASAN_OPTIONS = ("detect_leaks=0:halt_on_error=1:abort_on_error=0:exitcode=86:"
                "allocator_may_return_null=1:detect_odr_violation=0:print_summary=1")
UBSAN_OPTIONS = "halt_on_error=1:print_stacktrace=1:exitcode=87"

REPORT = re.compile(r"ERROR: AddressSanitizer|runtime error:|ERROR: LeakSanitizer|"
                    r"UndefinedBehaviorSanitizer")
"""A sanitizer's report in a child's output."""

ARMS = {
    # arm: (spec or builder, the engine plugins its plant uses)
    "planar2": "torque sources, hybrid friction",
    "crane3": "maniplab.hydraulic",
    "erector": "maniplab.hydraulic with relief valves",
    "erector_pinned": "maniplab.cylinder",
    "lugre-block": "maniplab.lugre",
}


def lugre_block() -> Any:
    """A 1 kg block on a prismatic joint with LuGre friction (the only built-in friction law no
    built-in arm uses)."""
    import maniplab as ml

    return ml.ManipulatorSpec.from_dict({
        "name": "lugre_block",
        "joints": [{"name": "x", "type": "P", "axis": "x", "body": {"mass": 1.0},
                    "friction": {"model": "lugre", "coulomb": 1.0, "static": 0.5,
                                 "viscous": 0.4, "stribeck_velocity": 1e-3,
                                 "sigma0": 1e5, "sigma1": 316.0}}],
    })


def spec_of(arm: str) -> Any:
    """The spec of an arm of :data:`ARMS`."""
    import maniplab as ml

    return lugre_block() if arm == "lugre-block" else ml.resolve_spec(arm)


def libasan() -> str:
    """The ASan runtime of the C compiler that builds the library (``gcc -print-file-name``)."""
    for cc in ("gcc", "cc"):
        try:
            out = subprocess.run([cc, "-print-file-name=libasan.so"], capture_output=True,
                                 text=True, check=True).stdout.strip()
        except (OSError, subprocess.CalledProcessError):
            continue
        if out and os.path.isabs(out) and os.path.exists(out):
            return out
    raise RuntimeError("no libasan.so: the sanitizers need gcc with its ASan runtime "
                       "(Debian: apt-get install gcc)")


def environment(base: dict[str, str] | None = None) -> dict[str, str]:
    """The environment of a sanitized child: the switch, the ASan runtime first, the options."""
    env = dict(os.environ if base is None else base)
    env.update(MANIPLAB_NATIVE_SANITIZE="1", LD_PRELOAD=libasan(), ASAN_OPTIONS=ASAN_OPTIONS,
               UBSAN_OPTIONS=UBSAN_OPTIONS, PYTHONFAULTHANDLER="1")
    env["PYTHONPATH"] = os.pathsep.join(
        [str(HERE), str(ROOT / "tests"), *filter(None, [env.get("PYTHONPATH")])])
    return env


def active() -> bool:
    """Whether this process runs with the sanitized library: the switch is on and the ASan
    runtime is loaded."""
    if os.environ.get("MANIPLAB_NATIVE_SANITIZE") != "1":
        return False
    try:
        maps = Path("/proc/self/maps").read_text()
    except OSError:
        return False
    return "libasan" in maps


def reexec_sanitized() -> None:
    """Run this script again in a sanitized process (when run as a script without it)."""
    if active():
        return
    argv = [sys.executable, *sys.argv]
    os.execve(sys.executable, argv, environment())


def examples(default: int) -> int:
    """Examples of a fuzz target: its ``default`` times ``$MANIPLAB_FUZZ_SCALE`` (1 unless set;
    ``make sanitize`` runs 5, the subset of ``make test`` 0.5), at least 1."""
    scale = float(os.environ.get("MANIPLAB_FUZZ_SCALE") or 1.0)
    return max(1, round(default * scale))


def fuzz_settings(default: int) -> Any:
    """Hypothesis settings of a fuzz target: a fixed sequence of examples (derandomize), no
    database, no deadline (ASan slows everything), ``examples(default)`` of them."""
    from hypothesis import HealthCheck, settings

    return settings(max_examples=examples(default), derandomize=True, database=None,
                    deadline=None, print_blob=True,
                    suppress_health_check=list(HealthCheck))


def run_child(argv: list[str], timeout: float = 600) -> subprocess.CompletedProcess[str]:
    """Run ``python argv...`` in a sanitized process (text output captured)."""
    return subprocess.run([sys.executable, *argv], env=environment(), capture_output=True,
                          text=True, timeout=timeout, cwd=ROOT, check=False)


def report_of(proc: subprocess.CompletedProcess[str]) -> str | None:
    """The sanitizer report (its first lines) in a child's output, or None."""
    text = proc.stdout + proc.stderr
    match = REPORT.search(text)
    if match is None:
        return None
    start = text.rfind("\n", 0, match.start()) + 1
    return "\n".join(text[start:].splitlines()[:40])
