"""The figure of runs' energies: where each run's pump energy went, runs side by side."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

from maniplab.sim.energy import LOSSES, EnergyReport

PARTS = (*LOSSES, "pump relief", "tank", "work", "compression")
"""The parts of a run's bar, bottom to top: the losses, then what is not lost."""


def _part(report: EnergyReport, part: str) -> float:
    """One part of a report's bar, kJ."""
    if part == "pump relief":
        return report.pump_relief / 1e3
    return report.total(part) / 1e3


def energy_figure(reports: Sequence[EnergyReport]) -> Figure:
    """One stacked bar per run: its pump energy split into the losses (meter-in, compensator,
    meter-out, leakage, relief, anti-cavitation, a fixed pump's relief), the tank line, the work
    on the pistons and the oil's compression, kJ; a black tick marks each run's pump energy
    (negative parts, work the loads did, are drawn below zero)."""
    fig = Figure(figsize=(1.6 + 1.3 * len(reports), 4.6), layout="constrained")
    ax = fig.add_subplot()
    x = np.arange(len(reports))
    up, down = np.zeros(len(reports)), np.zeros(len(reports))
    colors = dict(zip(PARTS, ("#d62728", "#ff7f0e", "#e377c2", "#1f77b4", "#aec7e8", "#393b79",
                              "#8c564b", "#9467bd", "#bcbd22", "#7f7f7f", "#c7c7c7", "#2ca02c",
                              "#17becf"), strict=True))
    for part in PARTS:
        values = np.array([_part(r, part) for r in reports])
        if not np.any(np.abs(values) > 0.0):
            continue
        base = np.where(values >= 0.0, up, down)
        ax.bar(x, values, 0.6, bottom=base, label=part.replace("_", "-"), color=colors[part])
        up += np.maximum(values, 0.0)
        down += np.minimum(values, 0.0)
    pumps = [r.pump / 1e3 for r in reports]
    ax.scatter(x, pumps, marker="_", s=900, color="black", zorder=3, label="pump")
    ax.axhline(0.0, color="black", linewidth=0.6)
    ax.set_xticks(x, [r.label for r in reports], rotation=20 if len(reports) > 3 else 0)
    ax.set_ylabel("energy [kJ]")
    ax.set_title("Where the pump's energy went", fontsize=10)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0), markerscale=0.3)
    return fig
