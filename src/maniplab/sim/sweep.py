"""Parameter sweeps: many variants of one arm simulated in parallel, stored as a RunSet.

Where no variant needs Python while it steps (no controller, every actuator computed inside
MuJoCo: torque sources, hydraulic cylinders), the variants run in threads of this process: the
plant in C releases the GIL for a whole run, so the threads run on all cores with no pickling and
no worker start-up, like ``mujoco.rollout`` but with maniplab's friction/limit automaton (which
rollout, stepping plain MuJoCo, cannot apply). Otherwise they run on local processes
(``concurrent.futures.ProcessPoolExecutor``). Any ``concurrent.futures.Executor`` can be given
instead, or a ``dask.distributed.Client`` for a cluster (its ``get_executor()`` is used). Runs
travel back to the caller, which writes them, so workers need no shared disk. A variant that
fails is reported with its parameters and does not stop the others. Ctrl-C (or any error of the
sweep itself) stops it at once: local workers are stopped (processes killed, threads at their
next pause; see ``maniplab.workers``) and the runs it wrote are removed.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import itertools
import os
import re
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from maniplab.atomic import check_target
from maniplab.builtin import resolve_spec
from maniplab.errors import ManiplabError
from maniplab.mjcf_gen.builder import arm_step_limit
from maniplab.mjcf_gen.timestep import default_step
from maniplab.progress import Progress
from maniplab.sim import budget
from maniplab.sim.params import format_parameters
from maniplab.sim.run import Run
from maniplab.sim.runset import Failure, RunSet
from maniplab.sim.simulate import simulate
from maniplab.spec import ManipulatorSpec, model_of
from maniplab.workers import (
    Threads,
    completed,
    interrupts_deferred,
    process_pool,
    stop_processes,
)

Variants = Mapping[str, Sequence[Any]] | Sequence[Mapping[str, Any]]


def variants(grid: Variants) -> list[dict[str, Any]]:
    """The override dicts of a sweep.

    Args:
        grid: a mapping path -> values (the full grid, last key varying fastest) or a list of
            override mappings (taken as they are).
    """
    if isinstance(grid, Mapping):
        keys = list(grid)
        for key in keys:
            if isinstance(grid[key], (str, bytes)) or not isinstance(grid[key], Sequence):
                raise ManiplabError(f"sweep values of {key!r} must be a list, got {grid[key]!r}")
        return [dict(zip(keys, combo)) for combo in itertools.product(*(grid[k] for k in keys))]
    return [dict(v) for v in grid]


def sweep(spec: ManipulatorSpec | str | os.PathLike[str], grid: Variants, *,
          out: str | os.PathLike[str], inputs: Mapping[str | int, Any] | None = None,
          duration: float, executor: Any = None, processes: int | None = None,
          progress: bool | None = None, **simulate_args: Any) -> RunSet:
    """Simulate every variant of ``spec`` and store the runs in the folder ``out``.

    Args:
        spec: the base arm (spec, file or built-in name).
        grid: ``{"end_effector.mass": [3000, 4000], "joints.q2.actuator.leakage": [1e-12, 1e-11]}``
            (every combination) or a list of override mappings.
        out: folder for the run files (``<index>_<parameters>.npz``; created if missing).
        inputs: as for :func:`maniplab.simulate` (signals must be picklable: ``ml.signals`` are).
        duration: simulated time per variant, s.
        executor: a ``concurrent.futures.Executor`` or a ``dask.distributed.Client``; default
            ``processes`` threads when no variant needs Python per step (see above), else a
            process pool of ``processes`` workers.
        processes: workers of the default pool (default: the machine's cores); 1 runs in this
            process.
        progress: show a progress bar (default: when stderr is a terminal).
        **simulate_args: more keyword arguments of :func:`maniplab.simulate` (dt, initial,
            controller, sample_dt, ...).

    Returns:
        A RunSet of the stored runs, in variant order, with ``failures`` for the variants that
        raised (their parameters and the one-line error).

    Raises:
        KeyboardInterrupt: Ctrl-C; the workers are stopped, no run of this sweep is left in
            ``out`` (nor ``out`` itself, if the sweep created it): the runs wait in a hidden
            staging folder inside ``out`` until all are done, so earlier runs of the same names
            stay intact until the sweep completes.
    """
    base = resolve_spec(spec)
    todo = variants(grid)
    # a duration no run can take is bad input, refused before the first variant (not N failures)
    budget.steps_of(duration, simulate_args.get("dt") or default_step(arm_step_limit(base)))
    folder = Path(out)
    created = not folder.exists()
    folder.mkdir(parents=True, exist_ok=True)
    job = _Job(base, dict(inputs or {}), duration, simulate_args)
    names: dict[int, str] = {}
    failures: list[Failure] = []
    threads = executor is None and not _needs_python(base, todo, simulate_args)
    pool = _executor(executor, processes, threads)
    staging = Path(tempfile.mkdtemp(prefix=".sweep-", suffix=".tmp", dir=folder))
    bar = Progress(len(todo), f"sweep {base.name}", progress)
    try:
        with interrupts_deferred():  # a process pool's submit takes its locks too
            futures = {pool.submit(job, overrides): i for i, overrides in enumerate(todo)}
        for future in completed(futures):
            i = futures[future]
            outcome = future.result()
            if isinstance(outcome, str):
                failures.append(Failure(todo[i], outcome))
            else:
                names[i] = f"{i:03d}_{_slug(todo[i])}.npz"
                outcome.save(staging / names[i])
            bar.step(format_parameters(todo[i]))
        pool.shutdown()
        paths = _commit(staging, folder, [names[i] for i in sorted(names)])
    except BaseException:
        _stop(pool)
        _discard(staging, folder if created else None)
        raise
    finally:
        bar.close()
    return RunSet(paths, failures=failures)


class _Job:
    """One variant's simulation, picklable for worker processes; returns the run or the error
    message."""

    def __init__(self, base: ManipulatorSpec, inputs: dict[str | int, Any], duration: float,
                 simulate_args: dict[str, Any]) -> None:
        self.base, self.inputs, self.duration, self.args = base, inputs, duration, simulate_args

    def __call__(self, overrides: dict[str, Any]) -> Run | str:
        try:
            args = {"progress": False, **self.args}
            return simulate(self.base, overrides=overrides, inputs=self.inputs,
                            duration=self.duration, label=format_parameters(overrides) or None,
                            **args)
        except ManiplabError as exc:
            return str(exc)
        except Exception as exc:  # noqa: BLE001 - a worker's bug must not stop the other variants
            return f"{exc.__class__.__name__}: {exc}"


class _InProcess(cf.Executor):
    """Runs submitted calls at once in this process (``processes=1``)."""

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> cf.Future:
        future: cf.Future = cf.Future()
        future.set_result(fn(*args, **kwargs))
        return future


def _needs_python(base: ManipulatorSpec, todo: list[dict[str, Any]],
                  simulate_args: Mapping[str, Any]) -> bool:
    """Whether some variant runs Python while it steps: a controller (shared by the variants, so
    each process gets its own copy), or an actuator MuJoCo does not compute itself."""
    if simulate_args.get("controller") is not None:
        return True
    for overrides in todo:
        try:
            spec = base.with_overrides(overrides)
        except ManiplabError:
            continue  # reported by the variant's job
        if not all(model_of(j).runs_in_mujoco() for j in spec.joints):
            return True
    return False


def _executor(executor: Any, processes: int | None, threads: bool) -> cf.Executor:
    if executor is None:
        if processes == 1:
            return _InProcess()
        workers = processes or os.cpu_count() or 1
        return Threads(workers) if threads else process_pool(workers)
    if hasattr(executor, "get_executor"):  # dask.distributed.Client
        return _Borrowed(executor.get_executor())
    if isinstance(executor, cf.Executor):
        return _Borrowed(executor)
    raise ManiplabError(f"executor must be a concurrent.futures.Executor or a "
                        f"dask.distributed.Client, got {type(executor).__name__}")


class _Borrowed(cf.Executor):
    """A caller's executor, used but not shut down when the sweep ends."""

    def __init__(self, inner: cf.Executor) -> None:
        self.inner = inner
        self.futures: list[cf.Future] = []

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> cf.Future:
        future = self.inner.submit(fn, *args, **kwargs)
        self.futures.append(future)
        return future

    def shutdown(self, wait: bool = True, **kwargs: Any) -> None:
        """Leave the caller's executor running; with ``cancel_futures``, drop our calls not yet
        started."""
        if kwargs.get("cancel_futures"):
            for future in self.futures:
                future.cancel()


def _stop(pool: cf.Executor) -> None:
    """Stop the sweep's pool at once (Ctrl-C or an error): no variant runs on, no worker is left."""
    if isinstance(pool, cf.ProcessPoolExecutor):
        stop_processes(pool)
    elif isinstance(pool, Threads):
        pool.stop()
    else:
        pool.shutdown(wait=True, cancel_futures=True)


def _commit(staging: Path, folder: Path, names: list[str]) -> list[Path]:
    """Move the runs saved in ``staging`` into ``folder`` (replacing runs of the same name) and
    remove ``staging``; returns their paths. Until this, the folder holds nothing of the sweep,
    so an interrupted sweep leaves it as it was."""
    paths = [folder / name for name in names]
    for path in paths:
        check_target(path)  # a folder of that name is refused before anything moves
    for name, path in zip(names, paths):
        os.replace(staging / name, path)
    staging.rmdir()
    return paths


def _discard(staging: Path, folder: Path | None) -> None:
    """Delete the runs of a stopped sweep (all in ``staging``), and ``folder`` if the sweep
    created it and it is empty; never raises (the error that stopped the sweep is the one to
    see)."""
    shutil.rmtree(staging, ignore_errors=True)
    if folder is not None:
        with contextlib.suppress(OSError):
            folder.rmdir()


def _slug(overrides: Mapping[str, Any]) -> str:
    text = format_parameters(overrides).replace(", ", "_").replace(" ", "-")
    return re.sub(r"[^A-Za-z0-9_.=+-]", "", text)[:80] or "base"
