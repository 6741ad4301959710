"""Reading a study's evaluations: the best candidate, the Pareto set, convergence, and the
evaluations as JSON and CSV rows."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from typing import Any

from maniplab.optimize.search import score
from maniplab.optimize.study import Study


def best(records: Sequence[dict[str, Any]], study: Study) -> dict[str, Any] | None:
    """The feasible record with the best first objective (the first of equals), or None."""
    feasible = [r for r in records if r["feasible"]]
    return min(feasible, key=lambda r: score(r, study)) if feasible else None


def _signed(record: dict[str, Any], study: Study) -> list[float]:
    return [(-1.0 if o.sense == "max" else 1.0) * float(record["metrics"][o.metric])
            for o in study.objectives]


def pareto(records: Sequence[dict[str, Any]], study: Study) -> list[dict[str, Any]]:
    """The feasible records no other feasible record dominates (each design once), sorted by the
    first objective."""
    unique: dict[str, dict[str, Any]] = {}
    for r in records:
        if r["feasible"] and all(math.isfinite(x) for x in _signed(r, study)):
            unique.setdefault(r["key"], r)
    points = {k: _signed(r, study) for k, r in unique.items()}
    front = []
    for k, r in unique.items():
        a = points[k]
        if not any(all(x <= y for x, y in zip(b, a)) and b != a for b in points.values()):
            front.append(r)
    return sorted(front, key=lambda r: _signed(r, study))


def convergence(records: Sequence[dict[str, Any]], study: Study) -> list[float]:
    """The best feasible first objective after each evaluation (NaN until one is feasible), in
    the objective's own sense."""
    out, best_score = [], math.inf
    sign = -1.0 if study.objectives[0].sense == "max" else 1.0
    for r in records:
        if r["feasible"]:
            best_score = min(best_score, score(r, study))
        out.append(sign * best_score if math.isfinite(best_score) else math.nan)
    return out


def _finite(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def rows(records: Sequence[dict[str, Any]], study: Study) -> list[dict[str, Any]]:
    """One plain row per evaluation: index, source, variables, feasibility, reason, metrics."""
    out = []
    for r in records:
        row: dict[str, Any] = {"index": r["index"], "phase": r.get("phase", "search"),
                               "source": r["source"], "key": r["key"]}
        row.update({v.name: _finite(x) for v, x in zip(study.variables, r["values"])})
        row.update(feasible=r["feasible"], violation=_finite(r["violation"]),
                   reason=r["reason"], seconds=r["seconds"])
        row.update({m: _finite(r["metrics"].get(m)) for m in study.metrics})
        out.append(row)
    return out


def to_csv(table: Sequence[dict[str, Any]]) -> str:
    """The rows as CSV text (a header of their keys)."""
    if not table:
        return ""
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=list(table[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(table)
    return text.getvalue()
