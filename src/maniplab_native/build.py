"""Building and loading maniplab's plugin library (standard library only).

The library is compiled from the C sources next to this file against the installed mujoco's
headers and ``libmujoco``, into ``<cache>/plugins/<key>/``; the key hashes the sources, the mujoco
headers and library, and the compiler, so an upgrade of any of them builds afresh. The file is
written under a temporary name and renamed into place, so concurrent first uses (test workers,
sweep processes) each see a whole library.

``MANIPLAB_NATIVE_SANITIZE=1`` builds it (and, while it is set, an FMU's C functions, which
:mod:`maniplab.fmu.build` compiles with :data:`CFLAGS`) with AddressSanitizer and UBSan
(:data:`SANITIZE_FLAGS`) into ``<cache>/plugins-sanitize/<key>/`` instead, so the sanitized build
never replaces the normal one. The flags are read when this module is imported. Such a library
loads only into a process that has the ASan runtime first, e.g. ``LD_PRELOAD=$(gcc
-print-file-name=libasan.so) ASAN_OPTIONS=detect_leaks=0 python ...`` (CPython's own allocations
look like leaks); ``make sanitize`` runs the native tests and the fuzzing of ``tests/sanitize/``
that way (see the safety page's "Sanitizers").
"""

from __future__ import annotations

import ctypes
import hashlib
import importlib.util
import os
import shlex
import shutil
import signal
import subprocess
import sysconfig
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

PLUGINS = ("maniplab.hydraulic", "maniplab.cylinder", "maniplab.lugre")
"""The MuJoCo plugins the library registers."""


def sources() -> list[Path]:
    """The library's C sources and headers: every ``*.c`` and ``*.h`` next to this file."""
    return sorted([*_HERE.glob("*.c"), *_HERE.glob("*.h")])


SANITIZE_FLAGS = ("-g", "-fsanitize=address,undefined", "-fno-omit-frame-pointer",
                  "-fno-sanitize-recover=undefined")
"""The flags ``MANIPLAB_NATIVE_SANITIZE=1`` adds: AddressSanitizer and UBSan, which stop the
process at the first error with a report."""


def sanitizing() -> bool:
    """Whether ``MANIPLAB_NATIVE_SANITIZE`` asks for the sanitized build (``1``, ``yes``,
    ``true``, ``on``)."""
    return os.environ.get("MANIPLAB_NATIVE_SANITIZE", "").strip().lower() in (
        "1", "yes", "true", "on")


CFLAGS = ("-O2", "-fPIC", "-shared", "-ffp-contract=off", "-fno-math-errno", "-std=c99",
          *(SANITIZE_FLAGS if sanitizing() else ()))

_HERE = Path(__file__).resolve().parent
_LOCK = threading.Lock()
_LOADED: list[ctypes.CDLL] = []


class NativeBuildError(RuntimeError):
    """The plugin library could not be built or loaded (no C compiler, no mujoco headers)."""


def cache_root() -> Path:
    """maniplab's cache folder: ``$MANIPLAB_CACHE``, else ``$XDG_CACHE_HOME/maniplab`` or
    ``~/.cache/maniplab`` (not created here)."""
    env = os.environ.get("MANIPLAB_CACHE")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "maniplab"


def compiler_candidates() -> list[tuple[str, ...]]:
    """C compiler commands to try, in order: $MANIPLAB_CC, $CC, Python's CC, cc, gcc, clang.

    ``MANIPLAB_CC=none`` means no compiler (an empty list)."""
    if os.environ.get("MANIPLAB_CC", "").lower() == "none":
        return []
    names = [os.environ.get("MANIPLAB_CC"), os.environ.get("CC"), sysconfig.get_config_var("CC"),
             "cc", "gcc", "clang"]
    out = []
    for name in names:
        command = tuple(shlex.split(name)) if name else ()
        if command and shutil.which(command[0]) and command not in out:
            out.append(command)
    return out


def run_compiler(argv: list[str], timeout: float | None = None) -> subprocess.CompletedProcess[str]:
    """Run a compiler command, capturing its output (text).

    The compiler runs in a process group of its own: Ctrl-C at the terminal reaches only this
    process, whose KeyboardInterrupt (or the timeout, s) then kills the whole group (the driver
    and its cc1, as and ld) and reaps the driver before it propagates.

    Raises:
        subprocess.TimeoutExpired: after ``timeout`` seconds.
    """
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    except BaseException:
        _kill_group(proc)
        raise
    return subprocess.CompletedProcess(argv, proc.returncode, stdout, stderr)


def run_compilers(argvs: list[list[str]], jobs: int) -> list[subprocess.CompletedProcess[str]]:
    """Run compiler commands, at most ``jobs`` at a time, each as :func:`run_compiler` does.

    Their messages go to temporary files (a full pipe nobody reads would stall a compiler).
    Ctrl-C kills every running compiler's group before it propagates.

    Returns:
        One completed process per command, in the order of ``argvs``.
    """
    results: list[subprocess.CompletedProcess[str] | None] = [None] * len(argvs)
    running: dict[int, tuple[subprocess.Popen[str], Any]] = {}
    pending = list(range(len(argvs)))
    try:
        while pending or running:
            while pending and len(running) < max(1, jobs):
                i = pending.pop(0)
                log = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 (closed when it ends)
                running[i] = (subprocess.Popen(argvs[i], stdout=log, stderr=log, text=True,
                                               start_new_session=True), log)
            for i, (proc, log) in list(running.items()):
                if proc.poll() is not None:
                    log.seek(0)
                    results[i] = subprocess.CompletedProcess(argvs[i], proc.returncode, "",
                                                             log.read())
                    log.close()
                    del running[i]
            time.sleep(0.01)
    except BaseException:
        for proc, log in running.values():
            _kill_group(proc)
            log.close()
        raise
    return [r for r in results if r is not None]


def _kill_group(proc: subprocess.Popen[str]) -> None:
    """SIGKILL the process group that ``proc`` leads, reap ``proc`` and close its pipes."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass  # the group has already ended
    proc.wait()
    for stream in (proc.stdout, proc.stderr):
        if stream is not None:
            stream.close()


def _mujoco_dir() -> Path:
    spec = importlib.util.find_spec("mujoco")
    if spec is None or not spec.submodule_search_locations:
        raise NativeBuildError("maniplab's MuJoCo plugins: the mujoco package is not installed")
    return Path(next(iter(spec.submodule_search_locations)))


def _libmujoco(mujoco_dir: Path) -> Path:
    libs = sorted(mujoco_dir.glob("libmujoco.so*")) + sorted(mujoco_dir.glob("libmujoco*.dylib"))
    if not libs or not (mujoco_dir / "include" / "mujoco" / "mujoco.h").exists():
        raise NativeBuildError(
            f"maniplab's MuJoCo plugins: no libmujoco and headers in {mujoco_dir} "
            "(a mujoco wheel >= 3.2 ships both)")
    return libs[0]


def mujoco_paths() -> tuple[Path, Path]:
    """The installed mujoco package's folder (its headers in ``include/``) and its ``libmujoco``.

    Raises:
        NativeBuildError: mujoco is not installed, or has no library and headers.
    """
    mujoco_dir = _mujoco_dir()
    return mujoco_dir, _libmujoco(mujoco_dir)


def mujoco_licences() -> list[Path]:
    """The installed mujoco wheel's licence files (LICENSE and the third-party notices)."""
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        files = distribution("mujoco").files or []
    except PackageNotFoundError:
        return []
    return [Path(str(f.locate())) for f in files
            if "licenses/" in str(f) or Path(str(f)).name.startswith("LICENSE")]


def _key(mujoco_dir: Path, lib: Path, compiler: tuple[str, ...]) -> str:
    digest = hashlib.sha256()
    for path in sources():
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    for header in sorted((mujoco_dir / "include" / "mujoco").glob("*.h")):
        digest.update(header.read_bytes())
    stat = lib.stat()
    digest.update(f"{lib.name} {stat.st_size} {' '.join(compiler)} {CFLAGS}".encode())
    return digest.hexdigest()[:24]


def library_path() -> Path:
    """The built plugin library, building it first when the cache has none.

    Raises:
        NativeBuildError: no C compiler, no mujoco headers, or the compiler failed.
    """
    mujoco_dir = _mujoco_dir()
    lib = _libmujoco(mujoco_dir)
    compilers = compiler_candidates()
    if not compilers:
        raise NativeBuildError(
            "maniplab's MuJoCo plugins need a C compiler and none was found "
            "(tried $MANIPLAB_CC, $CC, cc, gcc, clang): install one, e.g. apt-get install gcc")
    compiler = compilers[0]
    kind = "plugins-sanitize" if SANITIZE_FLAGS[1] in CFLAGS else "plugins"
    folder = cache_root() / kind / _key(mujoco_dir, lib, compiler)
    target = folder / "libmaniplab_plugins.so"
    if target.exists():
        return target
    folder.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".so", dir=folder)
    os.close(fd)
    argv = [*compiler, *CFLAGS, f"-I{mujoco_dir / 'include'}",
            *[str(path) for path in sources() if path.suffix == ".c"], "-o", tmp,
            f"-L{mujoco_dir}", f"-l:{lib.name}", f"-Wl,-rpath,{mujoco_dir}", "-lm"]
    try:
        proc = run_compiler(argv, timeout=300)
        if proc.returncode != 0:
            lines = proc.stderr.strip().splitlines() or ["(no message)"]
            first = next((line for line in lines if "error" in line), lines[-1])
            raise NativeBuildError(f"maniplab's MuJoCo plugins: the C compiler failed: {first}")
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return target


def load() -> None:
    """Build (on first use) and load the plugin library; MuJoCo then knows :data:`PLUGINS`.

    Idempotent and thread-safe. This is the ``mujoco.plugins`` entry point.

    Raises:
        NativeBuildError: as :func:`library_path`, or the library does not load.
    """
    with _LOCK:
        if _LOADED:
            return
        path = library_path()
        try:
            _LOADED.append(ctypes.CDLL(str(path)))
        except OSError as exc:
            hint = (" (the sanitized build, MANIPLAB_NATIVE_SANITIZE=1, needs the ASan runtime "
                    "first: LD_PRELOAD=$(gcc -print-file-name=libasan.so))"
                    if SANITIZE_FLAGS[1] in CFLAGS else "")
            raise NativeBuildError(
                f"maniplab's MuJoCo plugins: cannot load {path}: {exc}{hint}") from exc


def library() -> ctypes.CDLL:
    """The loaded plugin library, for ctypes calls of its exported C functions (built and loaded
    on first use, see :func:`load`).

    Raises:
        NativeBuildError: as :func:`load`.
    """
    load()
    return _LOADED[0]
