"""Comparison plots: any signals of any runs overlaid, one row of subplots per signal.

Each run is one colour throughout the figure; the legend names each run by the parameters that
differ between the runs (``payload=3000, q2 leakage=1e-11``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from maniplab.atomic import atomic_path
from maniplab.errors import ManiplabError
from maniplab.friction.modes import FrictionMode
from maniplab.sim import params
from maniplab.sim.run import Run
from maniplab.spec import model_of
from maniplab.viz.units import display

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType

_DASHES = ("-", "--", ":", "-.")
"""Line style of the k-th run: runs that agree stay visible on top of each other."""
_STYLE: dict[RcKeyType, Any] = {
    "font.size": 9, "axes.titlesize": 9, "axes.labelsize": 9, "legend.fontsize": 8,
    "lines.linewidth": 1.3, "axes.grid": True, "grid.alpha": 0.3, "axes.spines.top": False,
    "axes.spines.right": False, "savefig.dpi": 150, "savefig.bbox": "tight",
}


class PlotError(ManiplabError, ValueError):
    """A plot was asked for no runs, or for signals or joints the runs do not have.

    It is also a ValueError, which :func:`maniplab.viz.tracking.tracking_figure` raised before.
    """


def compare(runs: Sequence[Run], signals: Sequence[str] = ("q",),
            joints: Sequence[str] | None = None, labels: Sequence[str] | None = None,
            title: str | None = None) -> Figure:
    """Overlay signals of several runs of the same arm.

    Args:
        runs: the runs (at least one).
        signals: signal names (``q``, ``qd``, ``dP``, ``iv``, ``tau_fric``, ``mode``, ...),
            ``ee_path`` for the end-effector path and ``tracking_error`` for the distance from
            the controller's reference (closed-loop runs); one row of subplots each.
        joints: joint names for the columns of per-joint signals (default: every joint where a
            per-joint signal is finite and changes in some run). A joint without a signal (ΔP
            of a pinned cylinder, pA of a lumped one) gets a panel saying so, not an empty plot.
        labels: legend entries (default: the parameters that differ between the runs).
        title: figure title (default: the arm's name).

    Returns:
        The matplotlib figure; save it with :func:`save_figure`.
    """
    if not runs:
        raise PlotError("no runs to plot")
    spec = runs[0].spec
    names = list(joints) if joints else _active_joints(runs, [s for s in signals
                                                              if s not in WHOLE_ARM])
    for name in names:
        spec.joint(name)  # raises SpecError naming the valid joints
    labels = list(labels) if labels else params.labels(
        [params.flatten_spec(r.spec) for r in runs], [r.label for r in runs])
    with matplotlib.rc_context(_STYLE):
        ncols = max(len(names), 1)
        # the object API (no pyplot): no global figure state, works headless
        fig = Figure(figsize=(2.8 * ncols + 0.6, 2.1 * len(signals)), layout="constrained")
        axes = fig.subplots(len(signals), ncols, squeeze=False)
        for row, signal in enumerate(signals):
            if signal in WHOLE_ARM:
                WHOLE_ARM[signal](fig, axes[row], runs, labels)
            else:
                for col, name in enumerate(names):
                    _plot_joint(axes[row, col], runs, labels, signal, spec.joint_index(name))
        handles, texts = axes[0, 0].get_legend_handles_labels()
        fig.suptitle(title or spec.name)
        fig.legend(handles, texts, loc="outside lower center", ncols=min(len(runs), 3), frameon=False)
    return fig


def _active_joints(runs: Sequence[Run], signals: Sequence[str]) -> list[str]:
    spec = runs[0].spec
    if not signals:
        return []
    for run in runs:
        for signal in signals:
            if signal not in run:
                raise PlotError(f"run {run.label!r} has no signal {signal!r}; it has "
                                f"{', '.join(run)}")
    active = np.zeros(spec.n, dtype=bool)
    for run in runs:
        for signal in signals:  # a joint active in any signal (ΔP on one joint, pA on another)
            values = np.asarray(run[signal], dtype=float)
            finite = np.isfinite(values).any(axis=0)
            varies = (np.nanmax(values, axis=0, initial=-np.inf, where=np.isfinite(values))
                      > np.nanmin(values, axis=0, initial=np.inf, where=np.isfinite(values)))
            active |= finite & varies
    return [name for name, keep in zip(spec.joint_names, active) if keep] or list(spec.joint_names)


def _plot_joint(ax, runs: Sequence[Run], labels: Sequence[str], signal: str, j: int) -> None:
    joint = runs[0].spec.joints[j]
    what, scale, unit = display(signal, joint.prismatic)
    for run in runs:
        if signal not in run:
            raise PlotError(f"run {run.label!r} has no signal {signal!r}; it has {', '.join(run)}")
    if not any(np.isfinite(np.asarray(run[signal], dtype=float)[:, j]).any() for run in runs):
        # the joint's actuator has no such state (ΔP of a pinned cylinder): say so, draw nothing
        ax.set_axis_off()
        ax.text(0.5, 0.5, f"{joint.name}: no {what}\n({_actuator_kind(joint)})",
                ha="center", va="center", transform=ax.transAxes, color="0.4")
        return
    for k, (run, label) in enumerate(zip(runs, labels)):
        values = np.asarray(run[signal], dtype=float)[:, j] * scale
        draw = ax.step if signal == "mode" else ax.plot
        draw(run.t, values, color=f"C{k}", label=label, linestyle=_DASHES[k % len(_DASHES)],
             **({"where": "post"} if signal == "mode" else {}))
    ax.set_title(f"{joint.name}: {what}")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"{what} [{unit}]" if unit else what)
    if signal == "mode":
        ax.set_yticks([m.value for m in FrictionMode], [m.name for m in FrictionMode])


def _actuator_kind(joint: Any) -> str:
    """What the joint's actuator records instead, in a few words."""
    try:
        states = model_of(joint).states
    except ManiplabError:  # a stored run's plugin that is not loaded
        states = ()
    shown = [display(s, joint.prismatic)[0] for s in states if s != "spool"]
    return f"its actuator has {', '.join(shown)}" if shown else "its actuator has no state"


def _plot_error(fig: Figure, row_axes: np.ndarray, runs: Sequence[Run],
                labels: Sequence[str]) -> None:
    """Distance of the end-effector from the controller's reference, mm, over time."""
    for ax in row_axes[1:]:
        fig.delaxes(ax)
    ax = row_axes[0]
    for k, (run, label) in enumerate(zip(runs, labels)):
        if "e_x" not in run:
            raise PlotError(f"run {run.label!r} has no tracking error: it is not a closed-loop run")
        error = np.linalg.norm(np.asarray(run["e_x"], dtype=float)[:, :3], axis=1) * 1e3
        ax.plot(run.t, error, color=f"C{k}", label=label, linestyle=_DASHES[k % len(_DASHES)])
    ax.set_title("tracking error")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("|x_d - x| [mm]")


def _plot_path(fig: Figure, row_axes: np.ndarray, runs: Sequence[Run], labels: Sequence[str]) -> None:
    """End-effector path projected on the two base axes along which it moves most."""
    for ax in row_axes[1:]:
        fig.delaxes(ax)
    ax = row_axes[0]
    paths = [np.asarray(run["ee_pos"], dtype=float) for run in runs]
    extent = np.ptp(np.vstack(paths), axis=0)
    a, b = sorted(np.argsort(extent)[-2:])
    for k, (path, label) in enumerate(zip(paths, labels)):
        ax.plot(path[:, a], path[:, b], color=f"C{k}", label=label)
        ax.plot(path[-1, a], path[-1, b], "o", color=f"C{k}", markersize=3)
    ax.set_title("end-effector path")
    ax.set_xlabel(f"{'xyz'[a]} [m]")
    ax.set_ylabel(f"{'xyz'[b]} [m]")
    ax.set_aspect("equal", adjustable="datalim")


def save_figure(fig: Figure, path: str | os.PathLike[str]) -> Path:
    """Save as PNG, SVG or PDF (by suffix) through a temporary file."""
    path = Path(path)
    fmt = path.suffix.lower().lstrip(".")
    if fmt not in ("png", "svg", "pdf"):
        raise PlotError(f"{path}: unknown figure format {fmt!r}; expected .png, .svg or .pdf")
    with atomic_path(path) as tmp, matplotlib.rc_context(_STYLE):
        fig.savefig(tmp, format=fmt)
    return path


WHOLE_ARM = {"ee_path": _plot_path, "tracking_error": _plot_error}
"""Signals drawn as one plot for the whole arm (not one per joint)."""
