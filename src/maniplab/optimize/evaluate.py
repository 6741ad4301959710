"""Evaluating candidates: each one's spec built from the overrides, judged by the study's
metrics, on local processes or a Dask cluster, every evaluation served from or stored in the
cache.

A candidate the spec refuses (a pin that puts the cylinder beyond its stroke, a rod wider than
its bore) or whose evaluation refuses (a move out of reach) is infeasible, its one-line reason
kept. One that meets every constraint is feasible; otherwise its ``violation`` is the summed
relative distance to the constraints' bounds.
"""

from __future__ import annotations

import concurrent.futures as cf
import math
import time
from collections.abc import Sequence
from typing import Any

from maniplab.errors import ManiplabError
from maniplab.optimize.cache import Cache, candidate_key
from maniplab.optimize.paths import overrides_of, plain
from maniplab.optimize.study import Study
from maniplab.progress import Progress
from maniplab.spec import ManipulatorSpec
from maniplab.workers import completed, interrupts_deferred


class Job:
    """One candidate's evaluation, picklable for worker processes: the record of
    :func:`evaluate_candidate` without its key."""

    def __init__(self, base: ManipulatorSpec, study: Study) -> None:
        self.base, self.study = base, study

    def __call__(self, overrides: dict[str, Any]) -> dict[str, Any]:
        return evaluate_candidate(self.base, self.study, overrides)


def evaluate_candidate(base: ManipulatorSpec, study: Study,
                       overrides: dict[str, Any]) -> dict[str, Any]:
    """Judge one candidate: ``{"feasible", "reason", "metrics", "violation", "seconds"}``."""
    from maniplab.optimize.metrics import compute

    started = time.perf_counter()
    reason = None
    metrics: dict[str, float] = {}
    try:
        spec = base.with_overrides(overrides)
        metrics = compute(spec, study)
    except ManiplabError as exc:
        reason = str(exc)
    except Exception as exc:  # noqa: BLE001 - a candidate's crash must not stop the study
        reason = f"{exc.__class__.__name__}: {exc}"
    violation = 0.0 if reason is None else math.inf
    if reason is None:
        violation = sum(c.violation(metrics[c.metric]) for c in study.constraints)
    return {"feasible": reason is None and violation == 0.0, "reason": reason,
            "metrics": metrics, "violation": violation,
            "seconds": time.perf_counter() - started}


class Evaluator:
    """Evaluates batches of candidates through the cache and an executor, in a fixed order.

    Attributes:
        history: every evaluation asked for, in order (one per candidate, repeats included).
        computed: evaluations computed in this session; cached: served from the cache.
    """

    def __init__(self, base: ManipulatorSpec, study: Study, cache: Cache,
                 executor: cf.Executor | None, progress: bool | None = None) -> None:
        self.base, self.study, self.cache, self.executor = base, study, cache, executor
        self.job = Job(base, study)
        self.settings = study.settings()
        self.history: list[dict[str, Any]] = []
        self.computed = 0
        self.cached = 0
        # the baseline, the search, and the sensitivities (two neighbours per variable)
        total = 1 + study.budget + 2 * len(study.variables)
        self.bar = Progress(total, f"optimize {base.name}", progress)

    def key(self, overrides: dict[str, Any]) -> str:
        """The cache key of the candidate given by ``overrides``."""
        try:
            data: Any = self.base.with_overrides(overrides).to_dict()
        except ManiplabError:
            data = {"base": self.base.to_dict(), "overrides": overrides}
        return candidate_key(data, self.settings)

    def evaluate(self, candidates: Sequence[Sequence[Any]]) -> list[dict[str, Any]]:
        """The records of ``candidates`` (each a value per variable), in their order."""
        variables = self.study.variables
        records: list[dict[str, Any] | None] = []
        todo: dict[str, dict[str, Any]] = {}
        keys = []
        for values in candidates:
            values = [plain(v) for v in values]
            try:
                overrides = overrides_of(self.base, variables, values)
            except ManiplabError as exc:
                overrides = {v.name: x for v, x in zip(variables, values)}
                key = candidate_key({"bad": overrides}, self.settings)
                record = {"key": key, "feasible": False, "reason": str(exc), "metrics": {},
                          "violation": math.inf, "seconds": 0.0}
                self.cache.put(record)
            else:
                key = self.key(overrides)
            keys.append((key, values, overrides))
            stored = self.cache.get(key)
            records.append(stored)
            if stored is None and key not in todo:
                todo[key] = overrides
        self.cached += sum(1 for r in records if r is not None)
        for _ in range(sum(1 for r in records if r is not None)):
            self.bar.step("from the cache")
        fresh = self._compute(todo)
        out = []
        for (key, values, overrides), stored in zip(keys, records):
            record = dict(stored if stored is not None else fresh[key])
            record.update(values=values, overrides=overrides, index=len(self.history),
                          source="cache" if stored is not None else "computed")
            self.history.append(record)
            out.append(record)
        return out

    def _compute(self, todo: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
        results: dict[str, dict[str, Any]] = {}
        if self.executor is None:
            for key, overrides in todo.items():
                results[key] = self._store(key, self.job(overrides))
            return results
        with interrupts_deferred():
            futures = {self.executor.submit(self.job, overrides): key
                       for key, overrides in todo.items()}
        try:
            for future in completed(futures):
                key = futures[future]
                results[key] = self._store(key, future.result())
        except BaseException:  # Ctrl-C: a borrowed executor (Dask) drops what has not started
            for future in futures:
                future.cancel()
            raise
        return results

    def _store(self, key: str, record: dict[str, Any]) -> dict[str, Any]:
        record = {"key": key, **record}
        self.cache.put(record)
        self.computed += 1
        self.bar.step(f"{self.computed} computed, {self.cached} from the cache")
        return record
