"""Comparison plots of closed-loop runs against their reference (matplotlib, no display needed).

One figure: the Cartesian position error of each run, the end-effector coordinates against the
reference, and per moving joint (at most four) its pressures (ΔP of a lumped cylinder, pA and pB
of a pinned one) and its command in its actuator's unit.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from maniplab.control.metrics import command_unit
from maniplab.control.trajectory import Trajectory

if TYPE_CHECKING:
    from matplotlib.figure import Figure

_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b")


def _reference(trajectory: Trajectory, t: np.ndarray) -> np.ndarray:
    return np.array([trajectory.sample(float(tk)).position for tk in t])


def _moving_joints(runs: Sequence[Any], limit: int = 4) -> list[int]:
    """Joints with a pressure signal that move most (by range of q), at most ``limit``, in joint
    order."""
    span = np.zeros(runs[0].spec.n)
    for run in runs:
        q = np.asarray(run.q)
        span = np.maximum(span, q.max(axis=0) - q.min(axis=0))
    order = [int(i) for i in np.argsort(-span) if span[i] > 1e-6][:limit]
    return sorted(order)


def _pressures(run: Any, j: int) -> list[tuple[str, np.ndarray]]:
    """The joint's pressure signals, (name, values in Pa): ΔP, or pA and pB (none: a joint
    without pressures)."""
    out = []
    for name in ("dP", "pA", "pB"):
        if name in run and np.isfinite(np.asarray(run[name])[:, j]).any():
            out.append((name, np.asarray(run[name])[:, j]))
    return out


def tracking_figure(runs: Sequence[Any], trajectory: Trajectory,
                    labels: Sequence[str] | None = None, title: str | None = None) -> Figure:
    """A matplotlib Figure comparing ``runs`` (``ml.Run``) with the reference ``trajectory``."""
    from matplotlib.figure import Figure

    from maniplab.viz.plots import PlotError

    if not runs:
        raise PlotError("tracking_figure needs at least one run")
    labels = list(labels or [r.label for r in runs])
    joints = _moving_joints(runs)
    ncol = max(len(joints), 1)
    fig = Figure(figsize=(3.2 * max(ncol, 3), 9.0), layout="constrained")
    grid = fig.add_gridspec(4, ncol)
    ax_err = fig.add_subplot(grid[0, :])
    ax_pos = fig.add_subplot(grid[1, :])
    t_ref = np.asarray(runs[0].t)
    ref = _reference(trajectory, t_ref)
    for c, axis in enumerate("xyz"):
        ax_pos.plot(t_ref, ref[:, c], "k--", lw=1.0, label="reference" if c == 0 else None)
    for k, (run, label) in enumerate(zip(runs, labels)):
        colour = _COLOURS[k % len(_COLOURS)]
        t = np.asarray(run.t)
        r = ref if len(t) == len(t_ref) and np.allclose(t, t_ref) else _reference(trajectory, t)
        err = 1e3 * np.linalg.norm(run["ee_pos"] - r, axis=1)
        ax_err.semilogy(t, np.maximum(err, 1e-4), color=colour, label=label)
        for c in range(3):
            ax_pos.plot(t, run["ee_pos"][:, c], color=colour, lw=1.0)
        for col, j in enumerate(joints):
            name = run.spec.joint_names[j]
            ax_p = fig.add_subplot(grid[2, col]) if k == 0 else fig.axes[2 + 2 * col]
            ax_i = fig.add_subplot(grid[3, col]) if k == 0 else fig.axes[3 + 2 * col]
            pressures = _pressures(run, j)
            for p, (signal, values) in enumerate(pressures):
                ax_p.plot(t, values / 1e6, color=colour, ls=("-", "--")[p % 2],
                          label=signal if k == 0 and len(pressures) > 1 else None)
            if "dP_d" in run and k == 0 and np.isfinite(run["dP_d"][:, j]).any():
                ax_p.plot(t, run["dP_d"][:, j] / 1e6, color="k", lw=0.8, ls=":",
                          label="ΔP_d (first run)")
            ax_i.plot(t, run["ctrl"][:, j], color=colour)
            which = ", ".join("ΔP" if n == "dP" else n for n, _ in pressures) or "no pressure"
            ax_p.set_title(f"{name}: {which} [MPa]")
            unit = command_unit(run.spec.joints[j])
            ax_i.set_title(f"{name}: command [{unit}]" if unit else f"{name}: command")
            ax_i.set_xlabel("t [s]")
            if len(pressures) > 1 and k == 0:
                ax_p.legend(loc="best", fontsize="small")
    t0, t1 = trajectory.t0, trajectory.t0 + trajectory.duration
    for ax in (ax_err, ax_pos):
        ax.axvspan(t0, t1, color="0.92", zorder=0)
    ax_err.set_ylabel("|p_d - p| [mm]")
    ax_err.set_title("Cartesian position error (shaded: the move)")
    ax_err.legend(loc="best")
    ax_pos.set_ylabel("end-effector x, y, z [m]")
    ax_pos.legend(loc="best")
    for ax in fig.axes:
        ax.grid(True, alpha=0.3)
    fig.suptitle(title or f"{runs[0].spec.name}: closed-loop tracking")
    return fig
