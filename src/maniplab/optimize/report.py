"""The study's report: report.md with the figures beside it (matplotlib, no display needed).

- ``convergence.png``: every feasible candidate's first objective and the best so far, over the
  evaluations;
- ``pareto.png`` (several objectives): the feasible candidates of the first two objectives, the
  Pareto front and the baseline;
- ``loadchart.png`` (a study of the load chart): the capacity over reach (the largest payload at
  some pose reaching at least that far) of the baseline and the best, overlaid, with the
  required payloads;
- ``dutycycle.png`` (a study of a duty cycle): the baseline's and the best's runs again, one
  move after another: distance from the reference, the highest chamber pressure, pump energy;
- ``sensitivity.png``: d(first objective)/d(variable) at the best, each scaled by the variable's
  range (or its catalogue step) so that the bars compare.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.figure import Figure

from maniplab.atomic import write_text
from maniplab.optimize import results
from maniplab.optimize.names import unit

if TYPE_CHECKING:
    from maniplab.optimize.run import OptimizeResult
    from maniplab.optimize.study import Statics
    from maniplab.spec import ManipulatorSpec


def write_report(result: OptimizeResult, base: ManipulatorSpec) -> None:
    """Write the figures and report.md into ``result.out``."""
    from maniplab.viz.plots import save_figure

    study, folder = result.study, result.out
    figures = {"convergence.png": _convergence(result)}
    if len(study.objectives) > 1:
        figures["pareto.png"] = _pareto(result)
    if result.best_spec is not None and any(
            m in ("payload_min", "reach_max") or m.startswith("payload@") for m in study.metrics):
        figures["loadchart.png"] = _charts(result, base)
    if result.best_spec is not None and study.duty_cycle is not None:
        figures["dutycycle.png"] = _duty(result, base)
    if result.sensitivity:
        figures["sensitivity.png"] = _sensitivity(result)
    for name, fig in figures.items():
        save_figure(fig, folder / name)
    write_text(folder / "report.md", _markdown(result, base, list(figures)))


def _label(metric: str) -> str:
    u = unit(metric)
    return f"{metric} ({u})" if u else metric


def _convergence(result: OptimizeResult) -> Figure:
    study = result.study
    metric = study.objectives[0].metric
    fig = Figure(figsize=(6.4, 3.6), layout="constrained")
    ax = fig.add_subplot()
    index = [r["index"] for r in result.evaluations if r["feasible"]]
    value = [r["metrics"][metric] for r in result.evaluations if r["feasible"]]
    ax.plot(index, value, ".", color="0.6", label="feasible candidates")
    ax.plot(range(len(result.evaluations)), results.convergence(result.evaluations, study),
            color="C0", label="best so far")
    if result.baseline["feasible"]:
        ax.axhline(result.baseline["metrics"][metric], color="C3", ls="--", label="baseline")
    ax.set(xlabel="evaluation", ylabel=_label(metric),
           title=f"{result.method}: {study.objectives[0].sense} {metric}")
    ax.legend(loc="best", fontsize="small")
    return fig


def _pareto(result: OptimizeResult) -> Figure:
    study = result.study
    a, b = study.objectives[0].metric, study.objectives[1].metric
    fig = Figure(figsize=(5.6, 4.2), layout="constrained")
    ax = fig.add_subplot()
    feasible = [r for r in result.evaluations if r["feasible"]]
    ax.plot([r["metrics"][a] for r in feasible], [r["metrics"][b] for r in feasible], ".",
            color="0.65", label="feasible candidates")
    front = sorted(result.pareto, key=lambda r: r["metrics"][a])
    ax.plot([r["metrics"][a] for r in front], [r["metrics"][b] for r in front], "o-",
            color="C0", label="Pareto front")
    if result.baseline["reason"] is None:
        ax.plot(result.baseline["metrics"][a], result.baseline["metrics"][b], "*", ms=12,
                color="C3", label="baseline")
    ax.set(xlabel=_label(a), ylabel=_label(b), title="Pareto front")
    ax.legend(loc="best", fontsize="small")
    return fig


def capacity(spec: ManipulatorSpec, s: Statics) -> tuple[np.ndarray, np.ndarray]:
    """(reach, m; the largest payload at some pose reaching at least that far, kg), from the
    load chart, sorted by reach."""
    from maniplab.loadchart import load_chart

    chart = load_chart(spec, points=s.points, rating=s.rating, safety=s.safety,
                       stability=s.stability, slope=s.slope)
    order = np.argsort(chart.reach)
    reach, payload = chart.reach[order], chart.payload[order]
    envelope = np.maximum.accumulate(payload[::-1])[::-1]
    return reach, envelope


def _charts(result: OptimizeResult, base: ManipulatorSpec) -> Figure:
    s = result.study.statics
    fig = Figure(figsize=(6.4, 3.8), layout="constrained")
    ax = fig.add_subplot()
    assert result.best_spec is not None
    for spec, name, color in ((base, "baseline", "C3"), (result.best_spec, "best", "C0")):
        reach, payload = capacity(spec, s)
        ax.step(reach, np.where(np.isfinite(payload), payload, np.nan), where="post",
                color=color, label=name)
    for c in result.study.constraints:
        if c.metric.startswith("payload@") and c.low is not None:
            ax.plot(float(c.metric[len("payload@"):]), c.low, "kv", ms=8)
    ax.plot([], [], "kv", label="required")
    ax.set(xlabel="reach (m)", ylabel="payload held at that reach or beyond (kg)",
           title="load chart: baseline and best")
    ax.legend(loc="best", fontsize="small")
    return fig


def _duty(result: OptimizeResult, base: ManipulatorSpec) -> Figure:
    """The duty cycle of the baseline and the best, run again: the end-effector's distance from
    its reference (mm), the highest chamber pressure (MPa) and the pump's energy (kJ), over the
    cycle's time (the moves one after another)."""
    from maniplab.errors import ManiplabError
    from maniplab.optimize.metrics import duty_cycle

    fig = Figure(figsize=(7.0, 6.4), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    assert result.best_spec is not None
    for spec, name, color in ((base, "baseline", "C3"), (result.best_spec, "best", "C0")):
        try:
            _, runs = duty_cycle(spec, result.study)
        except ManiplabError:
            continue  # a refused baseline: no runs to draw
        offset, energy = 0.0, 0.0
        for k, run in enumerate(runs):
            t = np.asarray(run.t) + offset
            error = np.linalg.norm(np.asarray(run["x_d"])[:, :3] - np.asarray(run["ee_pos"]),
                                   axis=1) * 1e3
            pressure = np.nanmax(np.maximum(run["pA"], run["pB"]), axis=1) / 1e6
            pump = np.nansum(np.asarray(run["E_pump"]) - np.asarray(run["E_pump"])[0], axis=1)
            label = name if k == 0 else None
            axes[0].plot(t, error, color=color, label=label)
            axes[1].plot(t, pressure, color=color, label=label)
            axes[2].plot(t, (energy + pump) / 1e3, color=color, label=label)
            offset, energy = float(t[-1]), energy + float(pump[-1])
    axes[0].set(ylabel="distance from the\nreference (mm)", title="duty cycle: baseline and best")
    axes[1].set(ylabel="highest chamber\npressure (MPa)")
    axes[2].set(ylabel="pump energy (kJ)", xlabel="time over the cycle (s)")
    axes[0].legend(loc="best", fontsize="small")
    return fig


def _sensitivity(result: OptimizeResult) -> Figure:
    study = result.study
    names, values = [], []
    for v in study.variables:
        slope = result.sensitivity.get(v.name, math.nan)
        scale = 1.0 if v.choices else float(v.high - v.low)  # type: ignore[operator]
        names.append(v.name if v.choices else f"{v.name} (× range)")
        values.append(slope * scale)
    fig = Figure(figsize=(6.4, 0.5 + 0.45 * len(names) + 1.0), layout="constrained")
    ax = fig.add_subplot()
    ax.barh(range(len(names)), np.nan_to_num(values), color="C0")
    ax.set_yticks(range(len(names)), names, fontsize="small")
    ax.axvline(0.0, color="0.3", lw=0.8)
    ax.set(xlabel=f"change of {_label(study.objectives[0].metric)}",
           title="sensitivity at the best (finite differences)")
    return fig


def _markdown(result: OptimizeResult, base: ManipulatorSpec, figures: list[str]) -> str:
    study = result.study

    def number(x: Any) -> str:
        return f"{x:.6g}" if isinstance(x, float) else str(x)

    lines = [f"# Optimisation of {base.name}", "",
             (f"{result.method}, seed {study.seed}, {len(result.evaluations)} candidates "
              f"({result.computed} computed, {result.cached} from the cache), "
              f"{sum(1 for r in result.evaluations if r['feasible'])} feasible."), ""]
    if result.best is None:
        lines += ["No candidate was feasible. The most common reasons:", ""]
        reasons: dict[str, int] = {}
        for r in result.evaluations:
            key = r["reason"] or "constraints not met"
            reasons[key] = reasons.get(key, 0) + 1
        lines += [f"- {n} × {k}" for k, n in sorted(reasons.items(), key=lambda kv: -kv[1])[:5]]
    else:
        best = result.best
        lines += ["| | baseline | best |", "|---|---|---|"]
        for i, v in enumerate(study.variables):
            lines.append(f"| {v.name} | {number(result.baseline['values'][i])} | "
                         f"{number(best['values'][i])} |")
        for m in study.metrics:
            lines.append(f"| {_label(m)} | {number(result.baseline['metrics'].get(m, '—'))} | "
                         f"{number(best['metrics'][m])} |")
        if result.baseline["reason"]:
            lines += ["", f"The baseline is refused: {result.baseline['reason']}"]
    if len(study.objectives) > 1:
        lines += ["", f"{len(result.pareto)} designs on the Pareto front (pareto/*.yaml)."]
    lines.append("")
    lines += [f"![{name[:-4]}]({name})" for name in figures]
    return "\n".join(lines) + "\n"
