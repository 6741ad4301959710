"""The optimisers, each from a well-kept library, each seeded (same seed, same candidates):

- ``differential_evolution`` (scipy): continuous (and integer) variables, one objective. A
  derivative-free global search that needs no gradient of a simulation, whose population of a
  generation is evaluated as one batch (``updating="deferred"``), in parallel, in a fixed order.
  Infeasible candidates score worse than every feasible one (by their violation).
- ``nsga2`` (optuna's ``NSGAIISampler``): catalogue (categorical), integer and continuous
  variables together, one or several objectives (the Pareto front), constraints by optuna's
  constrained domination. Each generation is asked as one batch and told in order.
- ``nelder_mead`` (scipy): a local, derivative-free refinement of continuous variables under
  one objective, from the base design (or the middle of the bounds), one candidate at a time:
  for polishing a design a global search found, or a study whose baseline is already good;
- ``grid``: every combination, when all variables are discrete and the combinations fit the
  budget (a catalogue of sizes searched exhaustively: nothing to gain from a heuristic).

``auto`` picks grid when it fits, else differential evolution for one objective without
catalogue variables, else NSGA-II.
"""

from __future__ import annotations

import contextlib
import itertools
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from maniplab.optimize.study import Study, Variable

Batch = Callable[[Sequence[Sequence[Any]]], list[dict[str, Any]]]
"""Evaluates candidates (a value per variable each), returning their records in order."""

PENALTY = 1e12
"""A single-objective score of an infeasible candidate: PENALTY (1 + violation), and 1000
PENALTY for one the spec or its evaluation refused."""


def choose(study: Study) -> str:
    """The optimiser ``auto`` stands for (see the module's docstring)."""
    if study.optimizer != "auto":
        return study.optimizer
    size = grid_size(study.variables)
    if size is not None and size <= study.budget:
        return "grid"
    if len(study.objectives) == 1 and all(v.kind != "categorical" for v in study.variables):
        return "differential_evolution"
    return "nsga2"


def grid_size(variables: Sequence[Variable]) -> int | None:
    """The number of combinations of discrete variables (None: some variable is continuous)."""
    size = 1
    for v in variables:
        if v.kind == "continuous":
            return None
        size *= len(_levels(v))
    return size


def _levels(v: Variable) -> list[Any]:
    if v.choices:
        return list(v.choices)
    assert v.low is not None and v.high is not None
    return list(range(math.ceil(v.low), math.floor(v.high) + 1))


def score(record: dict[str, Any], study: Study) -> float:
    """A record's single-objective score, lower is better (see :data:`PENALTY`)."""
    if record["reason"] is not None:
        return 1000.0 * PENALTY
    if not record["feasible"]:
        return PENALTY * (1.0 + min(record["violation"], 1e6))
    objective = study.objectives[0]
    value = record["metrics"][objective.metric]
    value = -value if objective.sense == "max" else value
    return 1000.0 * PENALTY if math.isnan(value) else _clipped(value)


def _clipped(value: float) -> float:
    """An infinite metric (a payload no joint limits) as the largest finite number of its sign,
    so that it compares as it should."""
    return float(min(max(value, -1e300), 1e300))


def run_search(study: Study, batch: Batch, start: Sequence[Any] | None = None) -> str:
    """Search within ``study.budget`` evaluations; returns the optimiser used.

    ``start``: the base spec's values of the variables; where each lies within its variable's
    domain, the search starts from them too (differential evolution's first member, NSGA-II's
    first trial), so a study never ends worse than the design it started from.
    """
    method = choose(study)
    if start is not None and not all(_within(v, x) for v, x in zip(study.variables, start)):
        start = None
    if method == "grid":
        _grid(study, batch)
    elif method == "differential_evolution":
        _differential_evolution(study, batch, start)
    elif method == "nelder_mead":
        _nelder_mead(study, batch, start)
    else:
        _nsga2(study, batch, start)
    return method


def _within(v: Variable, x: Any) -> bool:
    if v.choices:
        return x in v.choices
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return False
    assert v.low is not None and v.high is not None
    return v.low <= x <= v.high and (not v.integer or float(x).is_integer())


def _grid(study: Study, batch: Batch) -> None:
    combos = list(itertools.product(*(_levels(v) for v in study.variables)))[: study.budget]
    batch(combos)


def population(study: Study) -> int:
    """Candidates per generation: the study's, else 15 per variable (scipy's default), within
    the budget."""
    n = len(study.variables)
    size = study.population or (15 * n if choose(study) == "differential_evolution" else 24)
    return max(4 if choose(study) == "differential_evolution" else 2, min(size, study.budget))


def _differential_evolution(study: Study, batch: Batch, start: Sequence[Any] | None) -> None:
    from scipy.optimize import Bounds, differential_evolution

    variables = study.variables
    if any(v.kind == "categorical" for v in variables):
        from maniplab.optimize.errors import StudyError

        raise StudyError("differential_evolution takes continuous and integer variables only; "
                         "use nsga2 for catalogue variables", file=study.source,
                         field="optimizer")
    n = len(variables)
    size = population(study)
    multiplier = max(1, math.ceil(size / n))
    # generations enough to spend the whole budget; the mapper stops within the last one
    generations = max(0, math.ceil(study.budget / max(5, multiplier * n)) - 1)
    low = np.array([v.low for v in variables], dtype=float)
    high = np.array([v.high for v in variables], dtype=float)
    integrality = np.array([v.integer for v in variables])

    spent = 0

    def mapper(_: Any, population: Any) -> list[float]:
        nonlocal spent
        candidates = [[round(float(x)) if v.integer else float(x) for v, x in zip(variables, row)]
                      for row in np.atleast_2d(np.asarray(list(population)))]
        left = study.budget - spent
        spent += len(candidates)
        if left < len(candidates):  # the budget ends within this generation
            batch(candidates[:left])
            raise _BudgetSpent
        return [score(r, study) for r in batch(candidates)]

    with contextlib.suppress(_BudgetSpent):
        differential_evolution(_unused, Bounds(low, high), seed=study.seed,
                               popsize=multiplier,
                               maxiter=generations, tol=0.0, atol=0.0, polish=False,
                               updating="deferred", workers=mapper, init="latinhypercube",
                               integrality=integrality if integrality.any() else None,
                               x0=None if start is None else np.asarray(start, dtype=float))


def _nelder_mead(study: Study, batch: Batch, start: Sequence[Any] | None) -> None:
    from scipy.optimize import Bounds, minimize

    variables = study.variables
    if any(v.kind != "continuous" for v in variables):
        from maniplab.optimize.errors import StudyError

        raise StudyError("nelder_mead takes continuous variables only", file=study.source,
                         field="optimizer")
    low = np.array([v.low for v in variables], dtype=float)
    high = np.array([v.high for v in variables], dtype=float)
    x0 = 0.5 * (low + high) if start is None else np.asarray(start, dtype=float)
    spent = 0

    def objective(x: np.ndarray) -> float:
        nonlocal spent
        if spent >= study.budget:
            raise _BudgetSpent
        spent += 1
        return score(batch([[float(v) for v in x]])[0], study)

    with contextlib.suppress(_BudgetSpent):
        minimize(objective, x0, method="Nelder-Mead", bounds=Bounds(low, high),
                 options={"maxfev": study.budget, "xatol": 0.0, "fatol": 0.0})


class _BudgetSpent(Exception):
    """The budget ended within differential evolution's first population."""


def _unused(x: Any) -> float:  # pragma: no cover - the mapper evaluates, through the cache
    raise AssertionError("differential evolution's function is evaluated by the mapper")


def _nsga2(study: Study, batch: Batch, start: Sequence[Any] | None) -> None:
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    size = population(study)
    # optuna >= 5 takes each trial's constraints from the trial (set_constraint); before, from
    # a function of the trial
    modern = hasattr(optuna.trial.Trial, "set_constraint")
    options: dict[str, Any] = {} if modern else {"constraints_func": _constraints}
    sampler = optuna.samplers.NSGAIISampler(population_size=size, seed=study.seed, **options)
    directions = [optuna.study.StudyDirection.MAXIMIZE if o.sense == "max" else
                  optuna.study.StudyDirection.MINIMIZE for o in study.objectives]
    search = optuna.create_study(directions=directions, sampler=sampler)
    if start is not None:
        search.enqueue_trial({f"x{i}": list(v.choices).index(x) if v.choices else x
                              for i, (v, x) in enumerate(zip(study.variables, start))})
    done = 0
    while done < study.budget:
        count = min(size, study.budget - done)
        trials = [search.ask() for _ in range(count)]
        candidates = [[_suggest(t, i, v) for i, v in enumerate(study.variables)] for t in trials]
        for trial, record in zip(trials, batch(candidates)):
            violation = record["violation"]
            violation = float(min(violation, PENALTY))
            if modern:
                trial.set_constraint("violation", violation)
            else:
                trial.set_user_attr("violation", violation)
            values = []
            for o in study.objectives:
                value = record["metrics"].get(o.metric, math.nan)
                if record["reason"] is not None or math.isnan(value):
                    value = -PENALTY if o.sense == "max" else PENALTY
                values.append(_clipped(value))
            search.tell(trial, values)
        done += count


def _constraints(trial: Any) -> list[float]:
    return [float(trial.user_attrs.get("violation", 0.0))]


def _suggest(trial: Any, i: int, v: Variable) -> Any:
    name = f"x{i}"
    if v.choices:
        return v.choices[trial.suggest_categorical(name, list(range(len(v.choices))))]
    assert v.low is not None and v.high is not None
    if v.integer:
        return trial.suggest_int(name, math.ceil(v.low), math.floor(v.high))
    return trial.suggest_float(name, v.low, v.high)
