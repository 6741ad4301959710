"""From a spec to loaded numeric kernels: record the recursive algorithms, print, compile, cache, load.

Backends:

- ``"c"``: each kernel in a C file of its own (math.h only), compiled in parallel on every core
  and linked with a small CPython extension (see ``cext``). Under a microsecond per call for a
  6-joint arm.
- ``"python"``: the same statements as Python source, evaluated with ``math`` for one state and
  with numpy over a batch. No compiler needed.

``"auto"`` takes C when a compiler and Python's headers are there, else Python.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.machinery
import importlib.util
import os
import shutil
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

import numpy as np

from maniplab.model import cache
from maniplab.model.cext import extension_source
from maniplab.model.compiler import compile_objects, find_compiler, link_shared
from maniplab.model.errors import ModelArgumentError
from maniplab.model.inertial import InertialParameters, inertial_parameters
from maniplab.model.parameters import structure_key
from maniplab.model.recursive import model_kernels
from maniplab.model.tape import TapeKernel, c_function, python_function
from maniplab.model.version import package_version
from maniplab.progress import Progress
from maniplab.spec import ManipulatorSpec


def generator_hash(folder: Path = Path(__file__).parent) -> str:
    """SHA-256 of the sources that generate the model (every module of this package): part of
    every cache key, so a changed generator never loads code an older one compiled."""
    digest = hashlib.sha256()
    for source in sorted(folder.glob("*.py")):
        digest.update(source.name.encode() + b"\0" + source.read_bytes() + b"\0")
    return digest.hexdigest()


_GENERATOR = generator_hash()

BACKENDS = ("auto", "c", "python")
_LOADED: dict[str, Any] = {}  # cache key -> loaded kernels, for this process
_LOCK = threading.Lock()


@dataclasses.dataclass
class Generated:
    """The recorded kernels of one arm structure.

    Attributes:
        n: degrees of freedom.
        params: the inertial parameters (the runtime vector's values and labels).
        kernels: one per function of the model.
    """

    n: int
    params: InertialParameters
    kernels: list[TapeKernel]


def generate(spec: ManipulatorSpec, progress: Progress | None = None) -> Generated:
    """Record the arm's kernels (RNEA, CRBA, Christoffel, kinematics) with runtime parameter slots."""
    params = inertial_parameters(spec)
    axes = ["xyz".index(j.axis.value) for j in spec.joints]
    kernels = model_kernels(params, axes, [j.prismatic for j in spec.joints])
    if progress:
        progress.step(f"recorded {sum(k.ops for k in kernels)} operations")
    return Generated(spec.n, params, kernels)


def python_kernels_source(gen: Generated, header: str = "") -> str:
    """Python source of all kernels; expects sin, cos (and sqrt) in its namespace."""
    parts = [header] + [python_function(k) + "\n\n" for k in gen.kernels]
    table = ", ".join(f"{k.name!r}: ({k.nin}, {k.output_shapes!r})" for k in gen.kernels)
    parts.append(f"# kernel name -> (how many of q, qd, qdd it reads, output shapes)\n"
                 f"KERNELS = {{{table}}}\n")
    return "\n".join(parts)


def cache_inputs(spec: ManipulatorSpec, backend: str) -> dict[str, Any]:
    """Everything the generated code depends on (hashed into the cache key)."""
    inputs: dict[str, Any] = {
        "structure": structure_key(spec), "n": spec.n, "maniplab": package_version(),
        "generator": _GENERATOR, "backend": backend,
    }
    if backend == "c":
        compiler = find_compiler()
        inputs["compiler"] = compiler.ident if compiler else None
        inputs["python"] = sys.implementation.cache_tag
        inputs["numpy"] = np.__version__
    return inputs


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
    bar = Progress(2 + (backend == "c"), f"maniplab: generating the {spec.name} model", progress)
    stage: Path | None = None
    try:
        bar.start(f"recording the recursive algorithms for {spec.n} joints")
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


def _write_entry(gen: Generated, stage: Path, backend: str, key: str, bar: Progress) -> None:
    """The files of a model entry in ``stage``: the kernels (a compiled extension with its C
    sources, or Python source) and the parameter labels."""
    header = f"/* maniplab generated model, structure {key[:16]} */"
    if backend == "c":
        module = _module_name(key)
        sources = []
        for k in gen.kernels:
            path = stage / f"{k.name}.c"
            path.write_text(f"{header}\n#include <math.h>\n\n{c_function(k)}\n")
            sources.append(path)
        wrapper = stage / f"{module}.c"
        wrapper.write_text(f"{header}\n" + extension_source(gen.kernels, module, gen.n,
                                                               len(gen.params.values)))
        compiler = find_compiler()
        assert compiler is not None, "resolve_backend chooses 'c' only with a compiler"
        bar.step(f"printed {len(sources) + 1} C files")
        jobs = os.cpu_count() or 1
        bar.start(f"compiling {len(sources) + 1} C files, {jobs} at a time")
        # the longest first, so the cores stay busy to the end
        files = sorted([*sources, wrapper], key=lambda f: -f.stat().st_size)
        objects = compile_objects(compiler, files, jobs=jobs, extension=True)
        link_shared(compiler, objects, stage / f"{module}.so")
        for obj in objects:
            obj.unlink()
        bar.step("compiled")
    else:
        (stage / "kernels.py").write_text(python_kernels_source(gen, f"# {header[3:-3]}"))
        bar.step("printed Python")
    (stage / "slots.txt").write_text("\n".join(gen.params.labels) + "\n")


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
        self._last_p: np.ndarray | None = None
        self._last_list: list[float] = []
        code = compile(source, str(folder / "kernels.py") if folder else "<kernels>", "exec")
        self._scalar: dict[str, Any] = {"sin": math.sin, "cos": math.cos, "sqrt": math.sqrt}
        self._vector: dict[str, Any] = {"sin": np.sin, "cos": np.cos, "sqrt": np.sqrt}
        # the code is the kernels this module generated (cached with a checksum), not user input
        exec(code, self._scalar)  # noqa: S102
        exec(code, self._vector)  # noqa: S102
        for name, (nin, shapes) in self._scalar["KERNELS"].items():
            setattr(self, name, self._wrap(name, nin, shapes))

    def _params(self, p: Any) -> list[float]:
        """``p`` as a list; a read-only array (the model's own) is converted once."""
        if isinstance(p, np.ndarray) and not p.flags.writeable:
            if p is not self._last_p:
                self._last_p, self._last_list = p, p.tolist()
            return self._last_list
        return np.asarray(p, dtype=float).tolist()

    def _wrap(self, name: str, nin: int, shapes: tuple[tuple[int, ...], ...]) -> Any:
        scalar, vector, n = self._scalar[name], self._vector[name], self.n
        sizes = [int(np.prod(s)) for s in shapes]

        def split(flat: np.ndarray, lead: tuple[int, ...]) -> Any:
            if len(shapes) == 1:
                return flat.reshape(*lead, *shapes[0])
            parts, start = [], 0
            for shape, size in zip(shapes, sizes):
                parts.append(flat[..., start:start + size].reshape(*lead, *shape).copy())
                start += size
            return parts[0] if len(parts) == 1 else tuple(parts)

        def call(p: Any, *states: Any) -> Any:
            if len(states) != nin:
                raise TypeError(f"{name}() takes {nin + 1} arguments ({len(states) + 1} given)")
            params = self._params(p)
            arrays = [np.asarray(s, dtype=float) for s in states]
            q = arrays[0]
            if q.shape == (n,):
                args = [a.tolist() for a in arrays] + [None] * (3 - nin)
                return split(np.array(scalar(params, *args)), ())
            if q.ndim != 2 or q.shape[1] != n or any(a.shape != q.shape for a in arrays):
                raise ValueError(f"{name}(): q must have shape ({n},) or (N, {n}), and qd, qdd its shape")
            cols = [list(a.T) for a in arrays] + [None] * (3 - nin)
            values = vector(params, *cols)
            out = np.empty((q.shape[0], len(values)))
            for i, v in enumerate(values):
                out[:, i] = v
            return split(out, (q.shape[0],))

        call.__name__ = name
        return call
