"""The plot pane's figures: the chosen signals of the ticked runs, every joint in its own labelled
subplot with its unit (one row per signal, one column per joint), each run in its colour with a
legend naming the run and the parameters in which the runs differ (payload, target, duration),
never bookkeeping such as the number of steps.

The same :class:`Panels` make the interactive plotly figure of the page (zoom, pan, a data
cursor on hover) and the exports: PNG and SVG through matplotlib, CSV of every sample.
"""

from __future__ import annotations

import csv
import dataclasses
import io
from collections.abc import Sequence
from typing import Any

import numpy as np

from maniplab.gui.units import Units
from maniplab.sim import params
from maniplab.sim.run import Run
from maniplab.viz import palette

LABELS = {
    "q": "position", "qd": "velocity", "dP": "load pressure ΔP", "Q": "valve flow",
    "iv": "valve current", "tau_fric": "friction", "mode": "friction mode",
    "tracking_error": "tracking error",
}
"""Words for the signals."""

POINTS = 2000
"""Samples per trace drawn at most (a longer run is thinned evenly; the CSV has them all)."""


@dataclasses.dataclass(frozen=True)
class Panel:
    """One subplot: a signal of one joint (column) of every run that has it."""

    signal: str
    column: int
    title: str
    unit: str
    row: int
    col: int
    per: float = 1.0
    """SI per unit shown (the values are divided by it)."""


def legend(runs: Sequence[Run], names: Sequence[str]) -> list[str]:
    """The run's name, and the parameters in which the runs differ: the spec's (payload,
    leakage...) and a move's target and asked duration, never the run's bookkeeping
    (``meta.steps``)."""
    sets = [{**params.flatten_spec(run.spec), **_move(run)} for run in runs]
    keys = params.differing(sets) if len(runs) > 1 else []
    return [name + (f" ({params.format_parameters({k: s.get(k) for k in keys})})" if keys else "")
            for name, s in zip(names, sets)]


def _move(run: Run) -> dict[str, Any]:
    move = run.meta.get("move")
    if not isinstance(move, dict):
        return {}
    out: dict[str, Any] = {}
    if "target" in move:
        out["target"] = tuple(round(float(x), 3) for x in move["target"])
    if "asked_duration" in move:
        out["move duration"] = float(move["asked_duration"])
    return out


def panels(runs: Sequence[Run], signals: Sequence[str], units: Units | None = None
           ) -> list[Panel]:
    """The subplots: one row per signal some run has, one column per joint (or component),
    in the page's ``units``."""
    units = units or Units()
    out = []
    row = 0
    for signal in signals:
        have = [run for run in runs if signal in run.signals]
        if not have:
            continue
        row += 1
        width = max(np.asarray(run.signals[signal]).reshape(len(run.t), -1).shape[1]
                    for run in have)
        spec = have[0].spec
        unit = str(have[0].units().get(signal, ""))
        for k in range(width):
            name = spec.joint_names[k] if width == spec.n and k < spec.n else f"{k + 1}"
            joint_unit, per = shown_unit(_unit(unit, spec, k) if width == spec.n else unit, units)
            title = f"{name}: {LABELS.get(signal, signal)}"
            out.append(Panel(signal, k, title, joint_unit, row, k + 1, per))
    return out


def _unit(unit: str, spec: Any, k: int) -> str:
    """A signal's SI unit for joint k: 'rad | m' resolved by the joint's type (a hydraulic
    joint's 'A | N·m | N' command is its current)."""
    if "|" not in unit:
        return unit
    parts = [u.strip() for u in unit.split("|")]
    if len(parts) == 3:
        return parts[0] if hasattr(spec.joints[k].actuator, "supply_pressure") else (
            parts[1] if spec.joints[k].type.value == "R" else parts[2])
    return parts[0] if spec.joints[k].type.value == "R" else parts[-1]


def shown_unit(unit: str, units: Units) -> tuple[str, float]:
    """(unit shown, SI per unit shown) of an SI unit in the page's units (Pa in MPa or bar,
    m³/s in L/min, rad in deg, m in mm when chosen)."""
    simple = {"Pa": "pressure", "m³/s": "flow", "rad": "angle", "m": "length"}
    if unit in simple:
        return units.scale(simple[unit])
    if unit in ("rad/s", "m/s"):
        shown, per = units.scale("angle" if unit == "rad/s" else "length")
        return f"{shown}/s", per
    return unit, 1.0


def _trace(run: Run, panel: Panel) -> tuple[np.ndarray, np.ndarray] | None:
    if panel.signal not in run.signals:
        return None
    values = np.asarray(run.signals[panel.signal], dtype=float).reshape(len(run.t), -1)
    if panel.column >= values.shape[1]:
        return None
    t = np.asarray(run.t, dtype=float)
    step = max(1, len(t) // POINTS)
    return t[::step], values[::step, panel.column] / panel.per


def figure(runs: Sequence[Run], names: Sequence[str], signals: Sequence[str],
           units: Units | None = None) -> Any:
    """The interactive plotly figure (zoom, pan, hover cursor), one subplot per panel."""
    from plotly.subplots import make_subplots  # type: ignore[import-untyped]

    cells = panels(runs, signals, units)
    if not cells:
        raise ValueError("none of the ticked runs has the signals chosen")
    rows, cols = max(p.row for p in cells), max(p.col for p in cells)
    titles = [""] * (rows * cols)
    for p in cells:
        titles[(p.row - 1) * cols + p.col - 1] = p.title
    fig = make_subplots(rows=rows, cols=cols, shared_xaxes=True, subplot_titles=titles,
                        horizontal_spacing=0.35 / cols if cols > 1 else 0.0,
                        vertical_spacing=0.12 / rows if rows > 1 else 0.0)
    labels = legend(runs, names)
    for k, (run, label) in enumerate(zip(runs, labels)):
        r, g, b = palette.to_uint8(palette.run_colour(k))
        shown = False
        for p in cells:
            data = _trace(run, p)
            if data is None:
                continue
            fig.add_scatter(x=data[0], y=data[1], mode="lines", name=label, legendgroup=label,
                            showlegend=not shown, line={"color": f"rgb({r},{g},{b})", "width": 1.5},
                            hovertemplate=f"{label}<br>t=%{{x:.4g}} s<br>%{{y:.4g}} {p.unit}"
                                          "<extra></extra>", row=p.row, col=p.col)
            shown = True
    for p in cells:
        fig.update_yaxes(title_text=f"[{p.unit}]" if p.unit else "", row=p.row, col=p.col,
                         title_standoff=2)
    for col in range(1, cols + 1):
        fig.update_xaxes(title_text="t [s]", row=rows, col=col)
    fig.update_annotations(font_size=11)
    fig.update_layout(margin={"l": 50, "r": 10, "t": 30, "b": 40}, hovermode="closest",
                      legend={"orientation": "h", "y": -0.08 - 0.1 / rows, "x": 0.0},
                      template="plotly_white", dragmode="zoom", font={"size": 10})
    return fig


def image(runs: Sequence[Run], names: Sequence[str], signals: Sequence[str],
          fmt: str = "png", units: Units | None = None) -> bytes:
    """The same panels as a PNG or SVG (matplotlib)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    cells = panels(runs, signals, units)
    if not cells:
        raise ValueError("none of the ticked runs has the signals chosen")
    rows, cols = max(p.row for p in cells), max(p.col for p in cells)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols + 1, 2.3 * rows + 1),
                             sharex=True, squeeze=False)
    labels = legend(runs, names)
    for ax in axes.flat:
        ax.set_visible(False)
    for p in cells:
        ax = axes[p.row - 1][p.col - 1]
        ax.set_visible(True)
        for k, run in enumerate(runs):
            data = _trace(run, p)
            if data is not None:
                ax.plot(data[0], data[1], color=palette.run_colour(k)[:3], lw=1.0,
                        label=labels[k])
        ax.set_title(p.title, fontsize=9)
        ax.set_ylabel(f"[{p.unit}]" if p.unit else "", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        if p.row == rows:
            ax.set_xlabel("t [s]", fontsize=8)
    handles, texts = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, texts, loc="lower center", ncol=min(len(texts), 3), fontsize=8)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    buffer = io.BytesIO()
    fig.savefig(buffer, format=fmt, dpi=110)
    plt.close(fig)
    return buffer.getvalue()


def table(runs: Sequence[Run], names: Sequence[str], signals: Sequence[str],
          units: Units | None = None) -> str:
    """Every sample of the plotted signals as CSV: one row per run and time, one column per
    panel (header: ``q1: position [rad]``)."""
    cells = panels(runs, signals, units)
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(["run", "t [s]", *(f"{p.title} [{p.unit}]" for p in cells)])
    for run, name in zip(runs, names):
        columns = []
        for p in cells:
            if p.signal in run.signals:
                values = np.asarray(run.signals[p.signal], dtype=float).reshape(len(run.t), -1)
                columns.append(values[:, p.column] / p.per if p.column < values.shape[1]
                               else np.full(len(run.t), np.nan))
            else:
                columns.append(np.full(len(run.t), np.nan))
        for i, t in enumerate(np.asarray(run.t, dtype=float)):
            writer.writerow([name, f"{t:.9g}", *(f"{c[i]:.9g}" for c in columns)])
    return out.getvalue()
