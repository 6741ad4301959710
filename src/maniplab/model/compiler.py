"""Finding a C compiler and building a shared library (CPython extension) from generated C."""

from __future__ import annotations

import dataclasses
import functools
import shlex
import subprocess
import sysconfig
from pathlib import Path

from maniplab_native.build import compiler_candidates, run_compiler, run_compilers

#: Flags: optimise; keep IEEE semantics (no fused multiply-add contraction, so C and the Python
#: fallback evaluate the same operations); -fno-math-errno only lets sin/cos be merged into sincos.
CFLAGS = ("-O2", "-fPIC", "-ffp-contract=off", "-fno-math-errno", "-w")


@dataclasses.dataclass(frozen=True)
class Compiler:
    """A working C compiler and what it needs to build an extension.

    Attributes:
        command: the compiler command (argv prefix), e.g. ["gcc"].
        version: its first ``--version`` line (part of cache keys).
        python_include: folder with Python.h, or None (then only ctypes can load the library).
        numpy_include: folder with numpy/arrayobject.h, or None.
    """

    command: tuple[str, ...]
    version: str
    python_include: str | None
    numpy_include: str | None

    @property
    def can_build_extension(self) -> bool:
        return self.python_include is not None and self.numpy_include is not None

    @property
    def ident(self) -> str:
        """What identifies the compiler's output: command, version, extension ability."""
        return f"{' '.join(self.command)} | {self.version} | ext={self.can_build_extension}"


@functools.cache
def find_compiler() -> Compiler | None:
    """The C compiler to use ($MANIPLAB_CC, $CC, Python's configured CC, cc, gcc or clang), or None.

    Set ``MANIPLAB_CC=none`` to pretend there is no compiler (the pure-Python backend is used).
    """
    for command in compiler_candidates():
        try:
            proc = run_compiler([*command, "--version"], timeout=30)
        except (OSError, subprocess.SubprocessError):
            continue
        if proc.returncode == 0:
            text = (proc.stdout or proc.stderr).strip()
            version = text.splitlines()[0] if text else ""
            return Compiler(command, version, _python_include(), _numpy_include())
    return None


def _python_include() -> str | None:
    include = sysconfig.get_paths().get("include")
    return include if include and Path(include, "Python.h").exists() else None


def _numpy_include() -> str | None:
    try:
        import numpy

        include = numpy.get_include()
    except (ImportError, AttributeError):
        return None
    return include if Path(include, "numpy", "arrayobject.h").exists() else None


class CompileError(RuntimeError):
    """The C compiler failed on generated code (a maniplab bug, or a broken toolchain)."""


def compile_objects(compiler: Compiler, sources: list[Path], *, jobs: int,
                    extension: bool) -> list[Path]:
    """Compile each C file to an object file beside it, ``jobs`` compilers at a time.

    Args:
        extension: give the compilers Python's and numpy's headers (for the CPython wrapper).

    Returns:
        The object files, in the order of ``sources``.

    Raises:
        CompileError: with the first failing compiler's message.
        KeyboardInterrupt: Ctrl-C; every running compiler is killed at once.
    """
    extra = ["-DML_PYTHON", f"-I{compiler.python_include}", f"-I{compiler.numpy_include}"] \
        if extension else []
    argvs = [[*compiler.command, *CFLAGS, "-c", *extra, str(src), "-o", str(src.with_suffix(".o"))]
             for src in sources]
    _check(argvs, run_compilers(argvs, jobs))
    return [src.with_suffix(".o") for src in sources]


def link_shared(compiler: Compiler, objects: list[Path], output: Path) -> None:
    """Link object files into the shared library ``output`` (removed again on Ctrl-C)."""
    argv = [*compiler.command, "-shared", *(str(o) for o in objects), "-o", str(output), "-lm"]
    try:
        proc = run_compiler(argv)
    except BaseException:
        output.unlink(missing_ok=True)
        raise
    _check([argv], [proc])


def _check(argvs: list[list[str]], procs: list[subprocess.CompletedProcess[str]]) -> None:
    for argv, proc in zip(argvs, procs):
        if proc.returncode != 0:
            raise CompileError(f"C compilation failed ({shlex.join(argv)}):\n{proc.stderr[-4000:]}")
