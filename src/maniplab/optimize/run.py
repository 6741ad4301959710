"""``optimize``: a study run end to end, its evaluations cached, its results written."""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import json
import math
import os
from pathlib import Path
from typing import Any

from maniplab.atomic import write_text
from maniplab.builtin import resolve_spec
from maniplab.errors import ManiplabError
from maniplab.optimize import results
from maniplab.optimize.cache import Cache
from maniplab.optimize.evaluate import Evaluator
from maniplab.optimize.search import run_search
from maniplab.optimize.study import Study, Variable, load_study
from maniplab.spec import ManipulatorSpec
from maniplab.workers import process_pool, stop_processes


@dataclasses.dataclass
class OptimizeResult:
    """A finished study.

    Attributes:
        study: the study.
        method: the optimiser used.
        evaluations: every search evaluation, in order (records: values, overrides, feasible,
            reason, metrics, source "computed" or "cache").
        baseline: the base spec's evaluation.
        best: the best feasible record by the first objective (several objectives: the Pareto
            design best by the first, then the next), or None.
        pareto: the feasible records no other dominates (several objectives).
        sensitivity: variable name -> d(first objective)/d(variable) at the best, by central
            finite differences (per unit of the variable; catalogue variables: per step to the
            neighbouring size), NaN where a neighbour is infeasible.
        computed, cached: evaluations computed in this call and served from the cache.
        out: the results folder.
        best_spec: the best candidate's spec (None: none feasible).
    """

    study: Study
    method: str
    evaluations: list[dict[str, Any]]
    baseline: dict[str, Any]
    best: dict[str, Any] | None
    pareto: list[dict[str, Any]]
    sensitivity: dict[str, float]
    computed: int
    cached: int
    out: Path
    best_spec: ManipulatorSpec | None


def optimize(study: str | os.PathLike[str] | dict[str, Any] | Study, *,
             out: str | os.PathLike[str], budget: int | None = None,
             processes: int | None = None, executor: Any = None, scheduler: str | None = None,
             resume: bool = False, progress: bool | None = None, report: bool = True,
             sensitivity: bool = True) -> OptimizeResult:
    """Run an optimisation study (see :mod:`maniplab.optimize.study` for its file).

    Args:
        study: a study file, its dict, or a loaded Study.
        out: the results folder (its ``cache/`` holds every evaluation).
        budget: search evaluations (overrides the study's).
        processes: local worker processes (default: the machine's cores; 1: in this process).
        executor: a ``concurrent.futures.Executor`` or ``dask.distributed.Client`` instead.
        scheduler: the address of a Dask scheduler instead (``tcp://host:8786``).
        resume: continue the study already in ``out`` (its cached evaluations are served, not
            computed again); without it a folder holding evaluations is refused.
        progress: a progress bar (default: when stderr is a terminal).
        report: write the figures and report.md.
        sensitivity: evaluate the finite differences at the best.

    Raises:
        StudyError: a bad study, one line.
        ManiplabError: ``out`` holds an earlier study and ``resume`` is not given.
        KeyboardInterrupt: Ctrl-C; the evaluations finished so far stay cached (``resume``).
    """
    if isinstance(study, Study):
        if budget is not None:
            study = dataclasses.replace(study, budget=budget)
    else:
        study = load_study(study, budget=budget)
    base = _base(study)
    _check_variables(base, study)
    _check_joints(base, study)
    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise ManiplabError(f"{folder}: exists and is not a folder")
    cache = Cache(folder / "cache")
    if len(cache) and not resume:
        raise ManiplabError(f"{folder} holds {len(cache)} evaluations of an earlier study; pass "
                            "--resume (resume=True) to continue it, or choose another folder")
    folder.mkdir(parents=True, exist_ok=True)
    pool, owned, client = _executor(executor, scheduler, processes)
    evaluator = Evaluator(base, study, cache, pool, progress)
    try:
        baseline = evaluator.evaluate([_base_values(base, study.variables)])[0]
        baseline["phase"] = "baseline"
        evaluator.history.clear()
        method = run_search(study, evaluator.evaluate, baseline["values"])
        history = list(evaluator.history)
        best = results.best(history, study)
        front = [best] if best else []
        if len(study.objectives) > 1:  # the best is the front's best by the first objective
            front = results.pareto(history, study)
            best = front[0] if front else None
        slopes = _sensitivity(evaluator, study, best) if sensitivity and best else {}
    except BaseException:
        if owned and isinstance(pool, cf.ProcessPoolExecutor):
            stop_processes(pool)
        raise
    finally:
        evaluator.bar.close()
        if client is not None:  # the Dask client this call opened for --scheduler
            client.close()
    if owned and pool is not None:
        pool.shutdown()
    best_spec = base.with_overrides(best["overrides"]) if best else None
    result = OptimizeResult(study, method, history, baseline, best, front, slopes,
                            evaluator.computed, evaluator.cached, folder, best_spec)
    _write(result, base)
    if report:
        from maniplab.optimize.report import write_report

        write_report(result, base)
    return result


def _base(study: Study) -> ManipulatorSpec:
    """The study's base spec; one that cannot be read is the study's error (field spec)."""
    from maniplab.errors import SpecError
    from maniplab.optimize.errors import StudyError

    try:
        return resolve_spec(study.spec)
    except SpecError as exc:
        raise StudyError(str(exc), file=study.source, field="spec") from None


def _check_joints(base: ManipulatorSpec, study: Study) -> None:
    """Each ``holding:JOINT`` metric names a joint of the arm."""
    from maniplab.optimize.errors import StudyError

    for kind, items in (("objectives", study.objectives), ("constraints", study.constraints)):
        for i, item in enumerate(items):
            metric = getattr(item, "metric", "")
            joint = metric[len("holding:"):] if metric.startswith("holding:") else None
            if joint is not None and joint not in base.joint_names and not (
                    joint.isdigit() and int(joint) < base.n):
                raise StudyError(f"{base.name} has no joint {joint!r}; its joints are "
                                 f"{', '.join(base.joint_names)}", file=study.source,
                                 field=f"{kind}[{i}].metric")


def _check_variables(base: ManipulatorSpec, study: Study) -> None:
    """Each variable's path exists in the spec (a bad path is the study's error, not every
    candidate's)."""
    from maniplab.errors import SpecError
    from maniplab.optimize.errors import StudyError
    from maniplab.optimize.paths import overrides_of

    for i, v in enumerate(study.variables):
        value = v.choices[0] if v.choices else v.low
        try:
            overrides = overrides_of(base, [v], [value])
            base.with_overrides(overrides)
        except SpecError as exc:
            if exc.problem.startswith("override ") or exc.problem.startswith("variable "):
                raise StudyError(exc.problem, file=study.source,
                                 field=f"variables[{i}].path") from None


def _base_values(base: ManipulatorSpec, variables: tuple[Variable, ...]) -> list[Any]:
    from maniplab.optimize.paths import value_at

    out = []
    for v in variables:
        value = value_at(base, v.path)
        out.append(value[v.index] if v.index is not None and isinstance(value, list) else value)
    return out


def _executor(executor: Any, scheduler: str | None, processes: int | None
              ) -> tuple[cf.Executor | None, bool, Any]:
    """(the executor, whether this call owns its pool, the Dask client it opened or None)."""
    if scheduler is not None:
        try:
            from dask.distributed import Client
        except ImportError:
            raise ManiplabError("--scheduler needs Dask: pip install 'maniplab[cluster]'") from None
        try:
            executor = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as exc:
            raise ManiplabError(f"cannot reach the Dask scheduler {scheduler}: {exc}") from None
        return executor.get_executor(), False, executor
    if executor is not None:
        if hasattr(executor, "get_executor"):
            return executor.get_executor(), False, None
        if isinstance(executor, cf.Executor):
            return executor, False, None
        raise ManiplabError(f"executor must be a concurrent.futures.Executor or a "
                            f"dask.distributed.Client, got {type(executor).__name__}")
    workers = processes or os.cpu_count() or 1
    return (None, False, None) if workers == 1 else (process_pool(workers), True, None)


def _sensitivity(evaluator: Evaluator, study: Study, best: dict[str, Any]) -> dict[str, float]:
    """d(first objective)/d(variable) at ``best`` by central differences (one-sided at a bound)."""
    metric = study.objectives[0].metric
    pairs = []
    for i, v in enumerate(study.variables):
        x = best["values"][i]
        if v.choices:
            k = list(v.choices).index(x) if x in v.choices else 0
            lo, hi = v.choices[max(k - 1, 0)], v.choices[min(k + 1, len(v.choices) - 1)]
            span = float(min(k + 1, len(v.choices) - 1) - max(k - 1, 0))
        else:
            assert v.low is not None and v.high is not None
            h = 1.0 if v.integer else 0.01 * (v.high - v.low)
            lo, hi = max(v.low, x - h), min(v.high, x + h)
            span = float(hi - lo)
        pairs.append((i, lo, hi, span))
    candidates = []
    for i, lo, hi, _ in pairs:
        for value in (lo, hi):
            values = list(best["values"])
            values[i] = value
            candidates.append(values)
    records = evaluator.evaluate(candidates)
    for r in records:
        r["phase"] = "sensitivity"
    out = {}
    for (i, _, _, span), low, high in zip(pairs, records[::2], records[1::2]):
        ok = low["reason"] is None and high["reason"] is None and span > 0
        out[study.variables[i].name] = (
            (high["metrics"][metric] - low["metrics"][metric]) / span if ok else math.nan)
    return out


def _write(result: OptimizeResult, base: ManipulatorSpec) -> None:
    """The evaluations (JSON, CSV), the best spec or the Pareto set (spec files), summary.json."""
    from maniplab.optimize.paths import plain
    from maniplab.spec.yaml_io import dump_yaml

    study, folder = result.study, result.out
    table = results.rows([result.baseline, *result.evaluations], study)
    write_text(folder / "evaluations.json", json.dumps(table, indent=1) + "\n")
    write_text(folder / "evaluations.csv", results.to_csv(table))
    header = f"# maniplab optimize: {base.name}, the best of {len(result.evaluations)} candidates"
    if result.best_spec is not None:
        write_text(folder / "best.yaml", header + "\n" + dump_yaml(result.best_spec.to_dict()))
    if len(study.objectives) > 1:
        pareto = folder / "pareto"
        pareto.mkdir(exist_ok=True)
        for old in pareto.glob("*.yaml"):
            old.unlink()
        for k, record in enumerate(result.pareto):
            spec = base.with_overrides(record["overrides"])
            values = ", ".join(f"{o.metric} {record['metrics'][o.metric]:.4g}"
                               for o in study.objectives)
            write_text(pareto / f"{k:03d}.yaml", f"# Pareto design {k}: {values}\n"
                       + dump_yaml(spec.to_dict()))

    def brief(record: dict[str, Any] | None) -> Any:
        if record is None:
            return None
        return {"values": {v.name: plain(x) for v, x in zip(study.variables, record["values"])},
                "metrics": {k: (x if math.isfinite(x) else None)
                            for k, x in record["metrics"].items()},
                "feasible": record["feasible"], "reason": record["reason"]}

    summary = {"spec": base.name, "method": result.method, "seed": study.seed,
               "budget": study.budget, "evaluations": len(result.evaluations),
               "computed": result.computed, "cached": result.cached,
               "feasible": sum(1 for r in result.evaluations if r["feasible"]),
               "baseline": brief(result.baseline), "best": brief(result.best),
               "pareto": [brief(r) for r in result.pareto] if len(study.objectives) > 1 else [],
               "sensitivity": {k: (x if math.isfinite(x) else None)
                               for k, x in result.sensitivity.items()}}
    write_text(folder / "summary.json", json.dumps(summary, indent=2) + "\n")
