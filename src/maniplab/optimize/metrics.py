"""What a candidate is judged by: the metrics a study's objectives and constraints name.

Statics, from the load chart (:func:`maniplab.load_chart`, the study's ``statics`` grid):

- ``payload_min``: the smallest payload held over the chart's poses, kg;
- ``payload@R``: the largest payload held at some pose reaching at least R m from the base's
  vertical axis, kg (0 when no pose reaches R);
- ``reach_max``: the farthest reach at which a payload is held, m;
- ``holding:JOINT``: the smallest force or torque the joint's actuator holds both ways
  (min(high, -low) of its holding range) over its range (``statics.holding_points`` points,
  limits included), N·m or N;
- ``mass``: the arm's bodies' mass, kg;
- ``frequency_min``: the arm's lowest natural frequency, Hz: the smallest |λ|/2π of the
  oscillatory modes (complex eigenvalues λ) of the plant linearised at rest, its pressures
  holding it (:func:`maniplab.linearize`), at the duty cycle's start, else mid-range;
- ``param:PATH``: the candidate's value at a dotted path (``[i]`` a component), its unit.

Dynamics, from the duty cycle (each move planned and run by ``maniplab control``'s
:func:`~maniplab.control.move.run_move`, from where the last ended):

- ``cycle_time``: the moves' durations (stretched where the actuators needed longer), s;
- ``rms_error``, ``final_error``: the worst move's, mm;
- ``peak_pressure``: the largest chamber or load pressure, MPa;
- ``pump_energy``, ``losses``: summed over the moves, kJ (pinned cylinders);
- ``saturation``: time with a command at its limit, s;
- ``health``: the worst verdict, 0 ok, 1 warnings, 2 failed.

A plugin metric is ``function(spec, runs) -> float`` (``runs``: the duty cycle's runs, empty
without one), named in the study's ``plugins``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from maniplab.errors import ManiplabError
from maniplab.optimize.names import DYNAMIC, HEALTH, INDEX

if TYPE_CHECKING:
    from maniplab.optimize.study import Study
    from maniplab.spec import ManipulatorSpec

def compute(spec: ManipulatorSpec, study: Study) -> dict[str, float]:
    """Every metric ``study`` reads, for the candidate ``spec``.

    Raises:
        ManiplabError: the candidate cannot be judged (a chart or a move refused, a run that
            failed): it is infeasible, and the one line is its reason.
    """
    metrics = study.metrics
    values: dict[str, float] = {}
    if any(m in ("payload_min", "reach_max") or m.startswith("payload@") for m in metrics):
        values.update(_chart_metrics(spec, study, metrics))
    runs: list[Any] = []
    if study.duty_cycle is not None and (any(m in DYNAMIC for m in metrics) or study.plugins):
        dynamics, runs = duty_cycle(spec, study)
        values.update({m: dynamics[m] for m in DYNAMIC if m in metrics})
    plugins = dict(study.plugins)
    for metric in metrics:
        if metric in values:
            continue
        if metric == "frequency_min":
            values[metric] = lowest_frequency(spec, study)
        elif metric == "mass":
            values[metric] = float(sum(j.body.mass for j in spec.joints if j.body is not None))
        elif metric.startswith("holding:"):
            values[metric] = holding(spec, metric[len("holding:"):], study)
        elif metric.startswith("param:"):
            values[metric] = _param(spec, metric[len("param:"):])
        elif metric in plugins:
            values[metric] = float(load_function(plugins[metric])(spec, runs))
    return values


def _chart_metrics(spec: ManipulatorSpec, study: Study, metrics: tuple[str, ...]
                   ) -> dict[str, float]:
    from maniplab.loadchart import load_chart

    s = study.statics
    chart = load_chart(spec, points=s.points, rating=s.rating, safety=s.safety,
                       stability=s.stability, slope=s.slope)
    payload, reach = chart.payload, chart.reach
    out = {"payload_min": float(np.min(payload)),
           "reach_max": float(np.max(reach[payload > 0.0], initial=0.0))}
    for metric in metrics:
        if metric.startswith("payload@"):
            r = float(metric[len("payload@"):])
            out[metric] = float(np.max(payload[reach >= r - 1e-9], initial=0.0))
    return out


def lowest_frequency(spec: ManipulatorSpec, study: Study) -> float:
    """The ``frequency_min`` metric, Hz (inf: no oscillatory mode)."""
    from maniplab.control.linearize import linearize

    if study.duty_cycle is not None and study.duty_cycle.start is not None:
        q = np.asarray(study.duty_cycle.start, dtype=float)
    else:
        q = np.array([0.5 * sum(j.limits) if j.limits else 0.0 for j in spec.joints])
    eigenvalues = np.linalg.eigvals(np.asarray(linearize(spec, q).A, dtype=float))
    modes = np.abs(eigenvalues[eigenvalues.imag > 1e-9 * np.maximum(1.0, np.abs(eigenvalues))])
    return float(np.min(modes) / (2 * math.pi)) if modes.size else math.inf


def holding(spec: ManipulatorSpec, joint: str, study: Study) -> float:
    """The smallest force or torque ``joint``'s actuator holds both ways over its range, N·m or
    N (the ``holding:JOINT`` metric)."""
    from maniplab.spec import model_of

    j = spec.joint_index(int(joint) if joint.isdigit() else joint)
    actuator = model_of(spec.joints[j])
    low, high = spec.joints[j].limits or (-math.pi, math.pi)
    s = study.statics
    worst = math.inf
    for q in np.linspace(low, high, s.holding_points):
        lo, hi = (actuator.holding_range(float(q)) if s.rating is None else
                  actuator.rated_holding_range(float(q), s.rating))
        worst = min(worst, hi / s.safety, -lo / s.safety)
    return float(worst)


def _param(spec: ManipulatorSpec, path: str) -> float:
    from maniplab.optimize.paths import value_at

    found = INDEX.match(path)
    value = value_at(spec, found["path"] if found else path)
    if found and isinstance(value, list):
        value = value[int(found["index"])]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ManiplabError(f"param:{path}: the spec's value there is {value!r}, not a number")
    return float(value)


def duty_cycle(spec: ManipulatorSpec, study: Study) -> tuple[dict[str, float], list[Any]]:
    """The duty cycle's metrics (the dynamic ones above) and its runs, one per move."""
    from maniplab.control.move import run_move
    from maniplab.model import AnalyticModel

    duty = study.duty_cycle
    assert duty is not None
    model = AnalyticModel(spec)
    start: Any = duty.start
    totals = {"cycle_time": 0.0, "rms_error": 0.0, "final_error": 0.0, "peak_pressure": 0.0,
              "pump_energy": 0.0, "losses": 0.0, "saturation": 0.0, "health": 0.0}
    runs = []
    for k, move in enumerate(duty.moves):
        try:
            result = run_move(spec, move.target, start=start, duration=move.duration,
                              mode=duty.mode, settle=duty.settle, model=model,
                              sample_dt=duty.sample_dt, tolerances=duty.tolerance)
        except ManiplabError as exc:
            raise ManiplabError(f"move {k + 1}: {exc}") from None
        m = result.metrics
        totals["cycle_time"] += result.plan.move.duration
        totals["rms_error"] = max(totals["rms_error"], m.rms_error_mm)
        totals["final_error"] = max(totals["final_error"], m.final_error_mm)
        totals["peak_pressure"] = max(totals["peak_pressure"], _number(m.peak_pressure_MPa))
        totals["pump_energy"] += _number(m.pump_energy_kJ)
        totals["losses"] += _number(m.losses_kJ)
        totals["saturation"] += m.saturation_s
        totals["health"] = max(totals["health"], HEALTH[result.health.verdict])
        runs.append(result.run)
        start = np.asarray(result.run.q)[-1]
    return totals, runs


def _number(value: float) -> float:
    return 0.0 if math.isnan(value) else float(value)


@functools.cache
def load_function(target: str) -> Callable[..., Any]:
    """The function a plugin names, ``module:function`` (a module on the path, or a file
    ``path/to/file.py:function``)."""
    import importlib
    import importlib.util

    module_name, _, name = target.rpartition(":")
    try:
        if module_name.endswith(".py"):

            spec = importlib.util.spec_from_file_location(f"_maniplab_metric_{abs(hash(module_name))}",
                                                          module_name)
            if spec is None or spec.loader is None:
                raise ImportError(module_name)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
        else:
            module = importlib.import_module(module_name)
        function = getattr(module, name)
    except (ImportError, AttributeError, OSError) as exc:
        raise ManiplabError(f"metric plugin {target!r}: cannot load it ({exc})") from None
    if not callable(function):
        raise ManiplabError(f"metric plugin {target!r}: not a function")
    return function
