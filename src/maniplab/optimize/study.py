"""The study file: the arm, the design variables, the evaluation and the goals of an optimisation.

A study is a YAML file (or the same dict)::

    spec: arm.yaml                  # a spec file (relative to the study file) or a built-in name
    seed: 1                         # same seed, same study: the same candidates, the same result
    budget: 200                     # candidate evaluations (--budget overrides it)
    optimizer: auto                 # auto, differential_evolution, nsga2, nelder_mead or grid
    variables:                      # dotted paths as for --set; [i] picks one vector component
      - {path: "joints.q3.actuator.cylinder.pins.child[0]", low: -0.6, high: -0.2}   # m
      - {path: joints.q3.actuator.cylinder.bore, catalogue: iso3320-bore, low: 0.063, high: 0.16}
      - {path: control.rate, low: 100, high: 400, integer: true}                     # Hz
    statics: {points: 9}            # the load chart's grid (points per joint), rating, safety
    duty_cycle:                     # moves run one after another under the cascade (or pid)
      start: [0.0, 0.2, -0.3]
      moves: [{target: [3.0, 0.0, 1.0], duration: 2.0}]
    objectives: [{metric: cycle_time, sense: min}, {metric: pump_energy, sense: min}]
    constraints: [{metric: "payload@3.0", min: 500}]
    plugins: {stiffness: "mypkg.metrics:stiffness"}     # metric name -> function(spec, runs)

The metrics are listed in :mod:`maniplab.optimize.metrics`. Every problem is one line naming the
file, the line and the field (``variables[1].low``); a :class:`StudyError`.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from maniplab.optimize.catalogue import CATALOGUES
from maniplab.optimize.errors import StudyError
from maniplab.optimize.names import INDEX, metric_problem

OPTIMIZERS = ("auto", "differential_evolution", "nsga2", "nelder_mead", "grid")
"""The optimisers a study may ask for (``auto``: see :func:`maniplab.optimize.search.choose`)."""



@dataclasses.dataclass(frozen=True)
class Variable:
    """One design variable.

    Attributes:
        path: dotted path as for ``--set`` (without the ``[i]``).
        index: the component of a vector value it sets (pins), or None for the whole value.
        low, high: bounds of a continuous or integer variable, in the path's unit.
        integer: the variable takes whole numbers only.
        choices: the values of a categorical variable (a catalogue), in order.
    """

    path: str
    index: int | None = None
    low: float | None = None
    high: float | None = None
    integer: bool = False
    choices: tuple[Any, ...] = ()

    @property
    def name(self) -> str:
        """The variable as written in the study (``path[i]``)."""
        return self.path if self.index is None else f"{self.path}[{self.index}]"

    @property
    def kind(self) -> str:
        """"continuous", "integer" or "categorical"."""
        return "categorical" if self.choices else "integer" if self.integer else "continuous"


@dataclasses.dataclass(frozen=True)
class Objective:
    """A metric to minimise or maximise (``sense``: "min" or "max")."""

    metric: str
    sense: str = "min"


@dataclasses.dataclass(frozen=True)
class Constraint:
    """A requirement: ``low <= metric <= high`` (either bound may be None)."""

    metric: str
    low: float | None = None
    high: float | None = None

    def violation(self, value: float) -> float:
        """How far ``value`` lies outside the bounds, relative to them (0: met; inf: NaN)."""
        if not math.isfinite(value) and not (value == math.inf and self.high is None) and not (
                value == -math.inf and self.low is None):
            return math.inf
        gap = 0.0
        if self.low is not None and value < self.low:
            gap += (self.low - value) / max(abs(self.low), 1e-12)
        if self.high is not None and value > self.high:
            gap += (value - self.high) / max(abs(self.high), 1e-12)
        return gap


@dataclasses.dataclass(frozen=True)
class Move:
    """One move of the duty cycle: the end-effector's target (m, and rad with roll, pitch, yaw)
    and the move's duration, s."""

    target: tuple[float, ...]
    duration: float


@dataclasses.dataclass(frozen=True)
class DutyCycle:
    """Moves run one after another from rest, each from where the last ended.

    Attributes:
        moves: the moves.
        start: the joint positions the first move starts from (None: all 0, within limits).
        mode: "cascade" or "pid" (the PID-only baseline).
        settle: time simulated after each move, s.
        sample_dt: the runs' recording interval, s (None: every step).
        tolerance: (final, RMS) position error allowed, mm (the health verdict checks them).
    """

    moves: tuple[Move, ...]
    start: tuple[float, ...] | None = None
    mode: str = "cascade"
    settle: float = 0.5
    sample_dt: float | None = 0.01
    tolerance: tuple[float, float] = (2.0, 5.0)


@dataclasses.dataclass(frozen=True)
class Statics:
    """The load chart's settings: grid points per joint, working pressure rating (Pa or None),
    safety factor, stability factor against tipping (with a machine base), ground slope
    (degrees); and the points over a joint's range for holding metrics."""

    points: int = 9
    rating: float | None = None
    safety: float = 1.0
    holding_points: int = 41
    stability: float = 1.0
    slope: float = 0.0


@dataclasses.dataclass(frozen=True)
class Study:
    """A validated study (see the module's docstring)."""

    spec: str
    variables: tuple[Variable, ...]
    objectives: tuple[Objective, ...]
    constraints: tuple[Constraint, ...] = ()
    statics: Statics = Statics()
    duty_cycle: DutyCycle | None = None
    plugins: tuple[tuple[str, str], ...] = ()
    seed: int = 0
    budget: int = 100
    optimizer: str = "auto"
    population: int | None = None
    source: str | None = dataclasses.field(default=None, compare=False)

    @property
    def metrics(self) -> tuple[str, ...]:
        """Every metric the study reads, objectives first, each once."""
        return tuple(dict.fromkeys([o.metric for o in self.objectives]
                                   + [c.metric for c in self.constraints]))

    def settings(self) -> dict[str, Any]:
        """What an evaluation depends on besides the candidate's spec (its cache key's part)."""
        return {"metrics": sorted(self.metrics), "statics": dataclasses.asdict(self.statics),
                "duty_cycle": None if self.duty_cycle is None else
                dataclasses.asdict(self.duty_cycle), "plugins": [list(p) for p in self.plugins]}


def load_study(source: str | os.PathLike[str] | Mapping[str, Any], *,
               budget: int | None = None) -> Study:
    """A study from a YAML file or a dict, validated (``budget`` overrides the file's).

    Raises:
        StudyError: one line naming the file, line and field.
    """
    from maniplab.spec.yaml_io import parse_yaml

    lines: dict[Any, int] = {}
    if isinstance(source, Mapping):
        data: Any = dict(source)
        file = None
        folder = Path.cwd()
    else:
        file = str(source)
        try:
            text = Path(source).read_text(encoding="utf-8")
        except OSError as exc:
            raise StudyError(f"cannot read the study: {exc.strerror or exc}", file=file) from None
        try:
            data, lines = parse_yaml(text, file)
        except StudyError:
            raise
        except Exception as exc:  # noqa: BLE001 - the YAML's own one-line error
            raise StudyError(getattr(exc, "problem", str(exc)), file=file,
                             line=getattr(exc, "line", None)) from None
        folder = Path(source).resolve().parent
    return _Reader(data, file, lines, folder).study(budget)


class _Reader:
    """Reads a study's plain data, each problem a StudyError naming the field."""

    def __init__(self, data: Any, file: str | None, lines: dict[Any, int], folder: Path) -> None:
        self.data, self.file, self.lines, self.folder = data, file, lines, folder

    def fail(self, loc: tuple[Any, ...], problem: str) -> StudyError:
        field = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in loc).lstrip(".")
        line = next((self.lines[loc[:k]] for k in range(len(loc), 0, -1)
                     if loc[:k] in self.lines), None)
        return StudyError(problem, file=self.file, field=field or None, line=line)

    def mapping(self, value: Any, loc: tuple[Any, ...], known: tuple[str, ...]) -> dict[str, Any]:
        if not isinstance(value, Mapping):
            raise self.fail(loc, f"expected a mapping, got {_shown(value)}")
        for key in value:
            if key not in known:
                import difflib

                close = difflib.get_close_matches(str(key), known, n=1)
                hint = f"; did you mean '{close[0]}'?" if close else \
                    f"; expected one of {', '.join(known)}"
                raise self.fail((*loc, str(key)), f"unknown key '{key}'{hint}")
        return dict(value)

    def number(self, value: Any, loc: tuple[Any, ...], *, positive: bool = False,
               optional: bool = False) -> Any:
        if value is None and optional:
            return None
        if isinstance(value, float) and math.isinf(value) and optional:
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
                value):
            raise self.fail(loc, f"expected a finite number, got {_shown(value)}")
        if positive and not value > 0:
            raise self.fail(loc, f"must be positive, got {value!r}")
        return float(value)

    def whole(self, value: Any, loc: tuple[Any, ...], least: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < least:
            raise self.fail(loc, f"expected a whole number of at least {least}, got "
                                 f"{_shown(value)}")
        return int(value)

    def numbers(self, value: Any, loc: tuple[Any, ...], sizes: tuple[int, ...]) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) not in sizes:
            raise self.fail(loc, f"expected a list of {' or '.join(map(str, sizes))} numbers, "
                                 f"got {_shown(value)}")
        return tuple(self.number(v, (*loc, i)) for i, v in enumerate(value))

    def study(self, budget: int | None) -> Study:
        d = self.mapping(self.data, (), ("spec", "seed", "budget", "optimizer", "population",
                                         "variables", "objectives", "constraints", "statics",
                                         "duty_cycle", "plugins"))
        for key in ("spec", "variables", "objectives"):
            if key not in d:
                raise self.fail((key,), "missing; a study names the arm (spec), its "
                                        "variables and at least one objective")
        spec = d["spec"]
        if not isinstance(spec, str) or not spec:
            raise self.fail(("spec",), f"expected a spec file or a built-in name, got "
                                       f"{_shown(spec)}")
        local = self.folder / spec
        if local.exists():
            spec = str(local)
        optimizer = d.get("optimizer", "auto")
        if optimizer not in OPTIMIZERS:
            raise self.fail(("optimizer",), f"unknown optimizer {_shown(optimizer)}; expected "
                                            f"one of {', '.join(OPTIMIZERS)}")
        variables = self.variables(d["variables"])
        kinds = {v.kind for v in variables}
        allowed = {"differential_evolution": {"continuous", "integer"},
                   "nelder_mead": {"continuous"}, "grid": {"integer", "categorical"}}
        if optimizer in allowed and not kinds <= allowed[optimizer]:
            takes = " and ".join(sorted(allowed[optimizer]))
            others = ", ".join(sorted(kinds - allowed[optimizer]))
            raise self.fail(("optimizer",), f"{optimizer} takes {takes} variables only; use "
                                            f"nsga2 (or auto) for {others} ones")
        objectives = self.objectives(d["objectives"])
        constraints = self.constraints(d.get("constraints") or [])
        plugins = self.plugins(d.get("plugins") or {})
        study = Study(
            spec=spec, variables=variables, objectives=objectives, constraints=constraints,
            statics=self.statics(d.get("statics") or {}),
            duty_cycle=None if d.get("duty_cycle") is None else self.duty(d["duty_cycle"]),
            plugins=plugins,
            seed=self.whole(d.get("seed", 0), ("seed",), 0),
            budget=budget if budget is not None else self.whole(d.get("budget", 100),
                                                                ("budget",), 1),
            optimizer=optimizer,
            population=None if d.get("population") is None else self.whole(
                d["population"], ("population",), 4),
            source=self.file)
        self.check_metrics(study, d)
        return study

    def variables(self, value: Any) -> tuple[Variable, ...]:
        if not isinstance(value, list) or not value:
            raise self.fail(("variables",), f"expected a list of at least one design variable, "
                                            f"got {_shown(value)}")
        out = []
        for i, item in enumerate(value):
            loc: tuple[Any, ...] = ("variables", i)
            v = self.mapping(item, loc, ("path", "low", "high", "integer", "choices", "catalogue"))
            path = v.get("path")
            if not isinstance(path, str) or not path:
                raise self.fail((*loc, "path"), f"expected a dotted path as for --set, got "
                                                f"{_shown(path)}")
            index = None
            found = INDEX.match(path)
            if found:
                path, index = found["path"], int(found["index"])
            choices: tuple[Any, ...] = ()
            if "catalogue" in v:
                if v["catalogue"] not in CATALOGUES:
                    raise self.fail((*loc, "catalogue"), f"unknown catalogue "
                                    f"{_shown(v['catalogue'])}; expected one of "
                                    f"{', '.join(CATALOGUES)}")
                choices = CATALOGUES[v["catalogue"]]
            if "choices" in v:
                if choices:
                    raise self.fail((*loc, "choices"), "give choices or a catalogue, not both")
                if not isinstance(v["choices"], list) or not v["choices"]:
                    raise self.fail((*loc, "choices"), f"expected a non-empty list, got "
                                                       f"{_shown(v['choices'])}")
                choices = tuple(v["choices"])
            integer = v.get("integer", False)
            if not isinstance(integer, bool):
                raise self.fail((*loc, "integer"), f"expected true or false, got "
                                                   f"{_shown(integer)}")
            if choices:
                if integer:
                    raise self.fail((*loc, "integer"), "a catalogue variable takes its values "
                                                       "from its list")
                if "catalogue" in v and ("low" in v or "high" in v):  # a range of the catalogue
                    low = self.number(v.get("low", -math.inf), (*loc, "low"), optional=True)
                    high = self.number(v.get("high", math.inf), (*loc, "high"), optional=True)
                    choices = tuple(c for c in choices if low - 1e-12 <= c <= high + 1e-12)
                    if not choices:
                        raise self.fail((*loc, "high" if "high" in v else "low"),
                                        f"no size of {v['catalogue']} lies within the bounds")
                elif "low" in v or "high" in v:
                    raise self.fail((*loc, "low" if "low" in v else "high"),
                                    "a list of choices has no bounds (a catalogue's range may)")
                out.append(Variable(path, index, choices=choices))
                continue
            for key in ("low", "high"):
                if key not in v:
                    raise self.fail((*loc, key), "missing; a variable has bounds (low, high) or "
                                                 "a list of choices or a catalogue")
            low, high = self.number(v["low"], (*loc, "low")), self.number(v["high"], (*loc, "high"))
            if not low < high:
                raise self.fail((*loc, "high"), f"must exceed low ({low:g}), got {high:g}")
            if integer and math.ceil(low) > math.floor(high):
                raise self.fail((*loc, "high"), f"no whole number between {low:g} and {high:g}")
            out.append(Variable(path, index, low, high, integer))
        names = [v.name for v in out]
        for i, name in enumerate(names):
            if name in names[:i]:
                raise self.fail(("variables", i, "path"), f"{name!r} is already a variable")
        return tuple(out)

    def objectives(self, value: Any) -> tuple[Objective, ...]:
        if not isinstance(value, list) or not value:
            raise self.fail(("objectives",), f"expected a list of at least one objective, got "
                                             f"{_shown(value)}")
        out = []
        for i, item in enumerate(value):
            loc: tuple[Any, ...] = ("objectives", i)
            o = self.mapping(item, loc, ("metric", "sense"))
            metric = self.metric(o.get("metric"), (*loc, "metric"))
            sense = o.get("sense", "min")
            if sense not in ("min", "max"):
                raise self.fail((*loc, "sense"), f"expected min or max, got {_shown(sense)}")
            out.append(Objective(metric, sense))
        return tuple(out)

    def constraints(self, value: Any) -> tuple[Constraint, ...]:
        if not isinstance(value, list):
            raise self.fail(("constraints",), f"expected a list, got {_shown(value)}")
        out = []
        for i, item in enumerate(value):
            loc: tuple[Any, ...] = ("constraints", i)
            c = self.mapping(item, loc, ("metric", "min", "max"))
            metric = self.metric(c.get("metric"), (*loc, "metric"))
            low = self.number(c.get("min"), (*loc, "min"), optional=True)
            high = self.number(c.get("max"), (*loc, "max"), optional=True)
            if low is None and high is None:
                raise self.fail((*loc, "min"), "a constraint needs a min, a max or both")
            if low is not None and high is not None and low > high:
                raise self.fail((*loc, "max"), f"must be at least min ({low:g})")
            out.append(Constraint(metric, low, high))
        return tuple(out)

    def metric(self, value: Any, loc: tuple[Any, ...]) -> str:
        if not isinstance(value, str) or not value:
            raise self.fail(loc, f"expected a metric's name, got {_shown(value)}")
        return value

    def statics(self, value: Any) -> Statics:
        s = self.mapping(value, ("statics",), ("points", "rating", "safety", "holding_points",
                                               "stability", "slope"))
        safety = self.number(s.get("safety", 1.0), ("statics", "safety"))
        stability = self.number(s.get("stability", 1.0), ("statics", "stability"))
        for key, factor in (("safety", safety), ("stability", stability)):
            if factor < 1.0:
                raise self.fail(("statics", key), f"a {key} factor is at least 1, got {factor:g}")
        slope = self.number(s.get("slope", 0.0), ("statics", "slope"))
        if not 0.0 <= slope < 90.0:
            raise self.fail(("statics", "slope"), f"a slope is in [0, 90) degrees, got {slope:g}")
        return Statics(points=self.whole(s.get("points", 9), ("statics", "points"), 2),
                       rating=self.number(s.get("rating"), ("statics", "rating"), positive=True,
                                          optional=True),
                       safety=safety,
                       holding_points=self.whole(s.get("holding_points", 41),
                                                 ("statics", "holding_points"), 2),
                       stability=stability, slope=slope)

    def duty(self, value: Any) -> DutyCycle:
        loc: tuple[Any, ...] = ("duty_cycle",)
        d = self.mapping(value, loc, ("moves", "start", "mode", "settle", "sample_dt",
                                      "tolerance"))
        moves_data = d.get("moves")
        if not isinstance(moves_data, list) or not moves_data:
            raise self.fail((*loc, "moves"), f"expected a list of moves {{target, duration}}, "
                                             f"got {_shown(moves_data)}")
        moves = []
        for i, item in enumerate(moves_data):
            mloc = (*loc, "moves", i)
            m = self.mapping(item, mloc, ("target", "duration"))
            if "target" not in m or "duration" not in m:
                raise self.fail((*mloc, "target" if "target" not in m else "duration"),
                                "missing; a move has a target [x, y, z] and a duration, s")
            moves.append(Move(self.numbers(m["target"], (*mloc, "target"), (3, 6)),
                              self.number(m["duration"], (*mloc, "duration"), positive=True)))
        start = None if d.get("start") is None else tuple(
            self.number(v, (*loc, "start", i)) for i, v in enumerate(
                d["start"] if isinstance(d["start"], list) else self._bad_start(d["start"])))
        mode = d.get("mode", "cascade")
        if mode not in ("cascade", "pid"):
            raise self.fail((*loc, "mode"), f"expected cascade or pid, got {_shown(mode)}")
        settle = self.number(d.get("settle", 0.5), (*loc, "settle"))
        if settle < 0:
            raise self.fail((*loc, "settle"), f"must be at least 0 s, got {settle:g}")
        tol = self.numbers(d.get("tolerance", [2.0, 5.0]), (*loc, "tolerance"), (2,))
        return DutyCycle(tuple(moves), start, mode, settle,
                         self.number(d.get("sample_dt", 0.01), (*loc, "sample_dt"),
                                     positive=True, optional=True), (tol[0], tol[1]))

    def _bad_start(self, value: Any) -> list[Any]:
        raise self.fail(("duty_cycle", "start"), f"expected a list of joint positions, got "
                                                 f"{_shown(value)}")

    def plugins(self, value: Any) -> tuple[tuple[str, str], ...]:
        if not isinstance(value, Mapping):
            raise self.fail(("plugins",), f"expected a mapping metric: 'module:function', got "
                                          f"{_shown(value)}")
        out = []
        for name, target in value.items():
            if not isinstance(target, str) or ":" not in target:
                raise self.fail(("plugins", str(name)), f"expected 'module:function', got "
                                                        f"{_shown(target)}")
            out.append((str(name), target))
        return tuple(out)

    def check_metrics(self, study: Study, d: dict[str, Any]) -> None:
        named: list[tuple[str, int, str]] = [
            *(("objectives", i, o.metric) for i, o in enumerate(study.objectives)),
            *(("constraints", i, c.metric) for i, c in enumerate(study.constraints))]
        for kind, i, metric in named:
            problem = metric_problem(metric, dict(study.plugins), study.duty_cycle is not None)
            if problem:
                raise self.fail((kind, i, "metric"), problem)


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
