"""From a spec to loaded numeric kernels: generate (symbolic, cse), compile or not, cache, load.

Backends:

- ``"c"``: the kernels as C (one translation unit with a small CPython extension, see ``cext``),
  compiled with the system's C compiler. About a microsecond per call for a 6-DOF arm.
- ``"python"``: the same eliminated expressions as Python source, evaluated with ``math`` for one
  state and with numpy over a batch. No compiler needed; tens of microseconds per call.

``"auto"`` takes C when a compiler and Python's headers are there, else Python.
"""

from __future__ import annotations

import dataclasses
import importlib.machinery
import importlib.util
import shutil
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

import numpy as np

from maniplab.model import cache
from maniplab.model.cext import extension_source
from maniplab.model.codegen import (
    GENERATOR_VERSION,
    CseKernel,
    c_function,
    c_printer,
    eliminate,
    model_kernels,
    python_function,
    python_printer,
)
from maniplab.model.compiler import compile_shared, find_compiler
from maniplab.model.dynamics import derive
from maniplab.model.engine import Engine, get_engine
from maniplab.model.errors import ModelArgumentError
from maniplab.model.parameters import ArmTerms, arm_terms, structure_key
from maniplab.model.version import package_version
from maniplab.progress import Progress
from maniplab.spec import ManipulatorSpec

BACKENDS = ("auto", "c", "python")
_LOADED: dict[str, Any] = {}  # cache key -> loaded kernels, for this process
_LOCK = threading.Lock()


@dataclasses.dataclass
class Generated:
    """The eliminated kernels of one arm structure.

    Attributes:
        n: degrees of freedom.
        terms: the parameters in slot mode (slot values and labels).
        kernels: the kernels after cse.
        engine: the symbolic library used.
    """

    n: int
    terms: ArmTerms
    kernels: list[CseKernel]
    engine: Engine


def symbols(engine: Engine, n: int) -> tuple[list[Any], list[Any], list[Any]]:
    """Joint position, velocity and acceleration symbols q0.., qd0.., qdd0.. (0-based)."""
    q, qd, qdd = ([engine.symbol(f"{v}{i}") for i in range(n)] for v in ("q", "qd", "qdd"))
    return q, qd, qdd


def generate(spec: ManipulatorSpec, progress: Progress | None = None,
             engine: Engine | None = None) -> Generated:
    """Derive the arm's equations with runtime parameter slots and eliminate subexpressions."""
    engine = engine or get_engine("auto")
    terms = arm_terms(spec, engine, slots=True)
    q, qd, qdd = symbols(engine, spec.n)
    ch, dyn = derive(spec, terms, q, qd, engine)
    if progress:
        progress.step("derived M, C, G")
    out = []
    for kernel in model_kernels(ch, dyn, qdd, engine):
        out.append(eliminate(kernel, engine))
        if progress:
            progress.step(f"cse {kernel.name}")
    return Generated(spec.n, terms, out, engine)


def c_kernels_source(gen: Generated, header: str = "") -> str:
    """Plain C source of all kernels (math.h only)."""
    printer = c_printer(gen.engine)
    parts = [header, "#include <math.h>", "",
             f"#define ML_N {gen.n}", f"#define ML_NP {max(len(gen.terms.slot_values), 1)}", ""]
    parts += [c_function(ck, printer) + "\n" for ck in gen.kernels]
    return "\n".join(parts)


def python_kernels_source(gen: Generated, header: str = "") -> str:
    """Python source of all kernels; expects sin, cos (and sqrt) in its namespace."""
    printer = python_printer(gen.engine)
    parts = [header] + [python_function(ck, printer) + "\n\n" for ck in gen.kernels]
    table = ", ".join(f"{ck.kernel.name!r}: ({ck.kernel.nin}, {ck.kernel.outputs!r})"
                      for ck in gen.kernels)
    parts.append(f"# kernel name -> (how many of q, qd, qdd it reads, output shapes)\n"
                 f"KERNELS = {{{table}}}\n")
    return "\n".join(parts)


def cache_inputs(spec: ManipulatorSpec, backend: str) -> dict[str, Any]:
    """Everything the generated code depends on (hashed into the cache key)."""
    inputs: dict[str, Any] = {
        "structure": structure_key(spec), "n": spec.n, "maniplab": package_version(),
        "generator": GENERATOR_VERSION, "backend": backend,
        "engine": _engine_ident(),
    }
    if backend == "c":
        compiler = find_compiler()
        inputs["compiler"] = compiler.ident if compiler else None
        inputs["python"] = sys.implementation.cache_tag
        inputs["numpy"] = np.__version__
    return inputs


def _engine_ident() -> str:
    engine = get_engine("auto")
    return f"{engine.name} {getattr(engine.module, '__version__', '?')}"


def resolve_backend(backend: str) -> str:
    """"c" or "python" for a requested backend.

    Raises:
        ModelArgumentError: for an unknown backend, or "c" where it cannot be built.
    """
    if backend not in BACKENDS:
        raise ModelArgumentError(
            f"unknown backend {backend!r}; expected one of {', '.join(BACKENDS)}")
    compiler = find_compiler()
    usable = compiler is not None and compiler.can_build_extension
    if backend == "auto":
        return "c" if usable else "python"
    if backend == "c" and not usable:
        raise ModelArgumentError("backend 'c' needs a C compiler and Python's and numpy's headers; "
                                 "none found (use backend='python' or 'auto')")
    return backend


def load_kernels(spec: ManipulatorSpec, backend: str = "auto", *, use_cache: bool = True,
                 progress: bool | None = None) -> Any:
    """Kernels for the arm's structure: from this process, the disk cache, or generated now.

    Returns:
        An object with one function per kernel, ``name(p, q[, qd[, qdd]]) -> ndarray``
        (see ``cext``), plus ``backend`` and ``key`` attributes.
    """
    backend = resolve_backend(backend)
    inputs = cache_inputs(spec, backend)
    key = cache.make_key(inputs)
    with _LOCK:
        if use_cache and key in _LOADED:
            return _LOADED[key]
        folder = cache.lookup(key, inputs) if use_cache else None
        if folder is None:
            folder = _build_entry(spec, backend, key, inputs, progress, use_cache)
        kernels = _load_entry(folder, backend, key, spec.n)
        if use_cache:
            _LOADED[key] = kernels
        return kernels


def _build_entry(spec: ManipulatorSpec, backend: str, key: str, inputs: dict[str, Any],
                 progress: bool | None, use_cache: bool) -> Path:
    bar = Progress(9 + (backend == "c"), f"maniplab: generating the {spec.name} model", progress)
    stage: Path | None = None
    try:
        gen = generate(spec, bar)
        stage = cache.staging() if use_cache else Path(tempfile.mkdtemp(prefix="maniplab-"))
        _write_entry(gen, stage, backend, key, bar)
        return cache.commit(stage, key, inputs) if use_cache else stage
    except BaseException:  # Ctrl-C or a failed compile: no half-built folder stays behind
        if stage is not None:
            shutil.rmtree(stage, ignore_errors=True)
        raise
    finally:
        bar.close()


def _write_entry(gen: Any, stage: Path, backend: str, key: str, bar: Progress) -> None:
    """The files of a model entry in ``stage``: the kernels (a compiled extension or Python
    source) and the slot labels."""
    header = f"/* maniplab generated model, structure {key[:16]} */"
    if backend == "c":
        module = _module_name(key)
        source = stage / f"{module}.c"
        source.write_text(c_kernels_source(gen, header) + extension_source(gen.kernels, module))
        compiler = find_compiler()
        assert compiler is not None, "resolve_backend chooses 'c' only with a compiler"
        compile_shared(compiler, source, stage / f"{module}.so", extension=True)
        bar.step("compiled")
    else:
        (stage / "kernels.py").write_text(python_kernels_source(gen, f"# {header[3:-3]}"))
    (stage / "slots.txt").write_text(
        "\n".join(gen.terms.slot_labels) + "\n" if gen.terms.slot_labels else "")


def _module_name(key: str) -> str:
    return f"_maniplab_{key[:20]}"


def _load_entry(folder: Path, backend: str, key: str, n: int) -> Any:
    if backend == "c":
        name = _module_name(key)
        path = folder / f"{name}.so"
        loader = importlib.machinery.ExtensionFileLoader(name, str(path))
        module_spec = importlib.util.spec_from_file_location(name, str(path), loader=loader)
        if module_spec is None:
            raise ImportError(f"cannot load the compiled model {path}", path=str(path))
        module = importlib.util.module_from_spec(module_spec)
        loader.exec_module(module)
        # the same identity attributes as PythonKernels
        vars(module).update(backend="c", key=key, folder=folder)
        return module
    return PythonKernels(n, (folder / "kernels.py").read_text(), key, folder)


class PythonKernels:
    """The pure-Python backend: generated source run with ``math`` (one state) or numpy (batch).

    Offers the extension's calling convention: ``name(p, q[, qd[, qdd]]) -> ndarray``.
    """

    backend = "python"

    def __init__(self, n: int, source: str, key: str, folder: Path | None) -> None:
        import math

        self.n, self.key, self.folder = n, key, folder
        code = compile(source, str(folder / "kernels.py") if folder else "<kernels>", "exec")
        self._scalar: dict[str, Any] = {"sin": math.sin, "cos": math.cos, "sqrt": math.sqrt}
        self._vector: dict[str, Any] = {"sin": np.sin, "cos": np.cos, "sqrt": np.sqrt}
        # the code is the kernels this module generated (cached with a checksum), not user input
        exec(code, self._scalar)  # noqa: S102
        exec(code, self._vector)  # noqa: S102
        for name, (nin, shapes) in self._scalar["KERNELS"].items():
            setattr(self, name, self._wrap(name, nin, shapes))

    def _wrap(self, name: str, nin: int, shapes: tuple[tuple[int, ...], ...]) -> Any:
        scalar, vector, n = self._scalar[name], self._vector[name], self.n
        sizes = [int(np.prod(s)) for s in shapes]

        def split(flat: np.ndarray, lead: tuple[int, ...]) -> Any:
            parts, start = [], 0
            for shape, size in zip(shapes, sizes):
                parts.append(flat[..., start:start + size].reshape(*lead, *shape).copy())
                start += size
            return parts[0] if len(parts) == 1 else tuple(parts)

        def call(p: Any, *states: Any) -> Any:
            if len(states) != nin:
                raise TypeError(f"{name}() takes {nin + 1} arguments ({len(states) + 1} given)")
            arrays = [np.asarray(s, dtype=float) for s in states]
            q = arrays[0]
            if q.shape == (n,):
                args = [a.tolist() for a in arrays] + [None] * (3 - nin)
                return split(np.array(scalar(np.asarray(p).tolist(), *args)), ())
            if q.ndim != 2 or q.shape[1] != n or any(a.shape != q.shape for a in arrays):
                raise ValueError(f"{name}(): q must have shape ({n},) or (N, {n}), and qd, qdd its shape")
            cols = [list(a.T) for a in arrays] + [None] * (3 - nin)
            values = vector(np.asarray(p).tolist(), *cols)
            out = np.empty((q.shape[0], len(values)))
            for i, v in enumerate(values):
                out[:, i] = v
            return split(out, (q.shape[0],))

        call.__name__ = name
        return call
