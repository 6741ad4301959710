"""The figure of a load chart: the largest payload over horizontal reach and height."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from maniplab.loadchart import CAUSES, LoadChart, LoadChartError

BINS = (48, 36)
"""Cells of the figure along reach and height."""

MARKERS = {"holding": ("o", "white"), "structure": ("s", "orange"), "tipping": ("^", "red")}
"""How the figure marks each cause: marker and colour."""


def load_chart_figure(chart: LoadChart, bins: tuple[int, int] = BINS) -> Figure:
    """Payload contours over reach and height, as crane makers draw them.

    Each cell shows the most any pose reaching it holds (the best configuration for that point);
    white cells are out of reach. A dashed line marks the spec's own payload (its end-effector
    mass), the rated load. Tonnes when the payloads are above a tonne, else kg. With a slew in
    the grid (a base or a slope), each pose is rated all round: the least over the slew's angles.
    A marker per cell says what limits it (holding, structure, tipping), when more than one
    cause limits the chart.
    """
    reach, height = chart.reach, chart.height
    pick = chart.all_round()
    payload, cause = chart.payload[pick], chart.cause[pick]
    finite = np.isfinite(payload)
    if not finite.any():
        raise LoadChartError(f"{chart.spec.name}: no joint limits the payload anywhere (every "
                             "actuator holds any force: give torque sources a limit)")
    scale, unit = (1e-3, "t") if np.median(payload[finite]) > 1000.0 else (1.0, "kg")
    edges_r = np.linspace(0.0, reach.max() * 1.02 + 1e-9, bins[0] + 1)
    edges_h = np.linspace(height.min() - 1e-9, height.max() + 1e-9, bins[1] + 1)
    best, which = _cell_maxima(reach[finite], height[finite], payload[finite] * scale,
                               edges_r, edges_h)
    fig = Figure(figsize=(7.0, 5.0), layout="constrained")
    ax = fig.add_subplot()
    mesh = ax.pcolormesh(edges_r, edges_h, best.T, cmap="viridis", shading="flat")
    fig.colorbar(mesh, ax=ax, label=f"largest payload [{unit}]")
    centres_r, centres_h = (edges_r[1:] + edges_r[:-1]) / 2, (edges_h[1:] + edges_h[:-1]) / 2
    if np.isfinite(best).sum() > 3:
        lines = ax.contour(centres_r, centres_h, best.T, levels=6, colors="white",
                           linewidths=0.8)
        ax.clabel(lines, fmt="%.3g", fontsize=7)
        rated = chart.spec.end_effector.mass * scale
        if np.nanmin(best) < rated < np.nanmax(best):
            ax.contour(centres_r, centres_h, best.T, levels=[rated], colors="red",
                       linestyles="--", linewidths=1.2)
    causes = cause[finite][which[which >= 0]]
    if len(set(causes.tolist()) - {""}) > 1:
        cells = np.argwhere(which >= 0)
        for name in CAUSES:
            at = cells[causes == name]
            if len(at):
                marker, colour = MARKERS[name]
                ax.scatter(centres_r[at[:, 0]], centres_h[at[:, 1]], s=5, marker=marker,
                           color=colour, edgecolors="none", label=name)
        ax.legend(title="limited by", fontsize=7, title_fontsize=7, loc="upper right",
                  markerscale=2.5, facecolor="0.55", framealpha=0.8)
    ax.set_xlabel("horizontal reach [m]")
    ax.set_ylabel("height [m]")
    rule = chart.rule.split("; friction")[0] + ("; all round the slew" if chart.slews else "")
    ax.set_title(f"{chart.spec.name}: largest payload held\n({rule}"
                 f"; red dashed: the rated {chart.spec.end_effector.mass * scale:.3g} {unit})",
                 fontsize=9, wrap=True)
    return fig


def _cell_maxima(x: np.ndarray, y: np.ndarray, values: np.ndarray, edges_x: np.ndarray,
                 edges_y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The largest value per cell of the grid ``edges_x`` x ``edges_y`` (NaN where none) and
    the index of the point that has it (-1 where none), each shape (len(edges_x) - 1,
    len(edges_y) - 1)."""
    ix = np.clip(np.searchsorted(edges_x, x, side="right") - 1, 0, len(edges_x) - 2)
    iy = np.clip(np.searchsorted(edges_y, y, side="right") - 1, 0, len(edges_y) - 2)
    shape = (len(edges_x) - 1, len(edges_y) - 1)
    best = np.full(shape, -np.inf)
    np.maximum.at(best, (ix, iy), values)
    which = np.full(shape, -1)
    cell = ix * shape[1] + iy
    order = np.lexsort((values, cell))  # by cell, then value: each cell's largest last
    last = np.r_[cell[order][1:] != cell[order][:-1], True]
    which.flat[cell[order][last]] = order[last]
    best[np.isinf(best)] = np.nan
    return best, which
