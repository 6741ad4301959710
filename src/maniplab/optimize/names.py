"""The names of the metrics a study may read, their units, and the ``[i]`` of a vector
component (the metrics themselves: :mod:`maniplab.optimize.metrics`)."""

from __future__ import annotations

import math
import re
from collections.abc import Collection

INDEX = re.compile(r"^(?P<path>.+)\[(?P<index>\d+)\]$")
"""A dotted path ending in a vector component, ``pins.child[0]``."""

STATIC = ("payload_min", "reach_max", "mass", "frequency_min")
DYNAMIC = ("cycle_time", "rms_error", "final_error", "peak_pressure", "pump_energy", "losses",
           "saturation", "health")
UNITS = {"payload_min": "kg", "payload@": "kg", "reach_max": "m", "mass": "kg",
         "frequency_min": "Hz",
         "cycle_time": "s", "rms_error": "mm", "final_error": "mm", "peak_pressure": "MPa",
         "pump_energy": "kJ", "losses": "kJ", "saturation": "s", "health": ""}
"""Unit of each metric (by name or prefix), for tables and figures."""

HEALTH = {"ok": 0.0, "warnings": 1.0, "failed": 2.0}


def unit(metric: str) -> str:
    """The unit a metric is given in ('' when it has none or it is a plugin's)."""
    return UNITS.get(metric, UNITS.get(metric.split("@")[0] + "@", "") if "@" in metric else "")


def metric_problem(metric: str, plugins: Collection[str], duty_cycle: bool) -> str | None:
    """Why ``metric`` cannot be computed in a study with these plugin metrics, and a duty cycle
    or not (None: it can)."""
    if metric in STATIC or metric in plugins:
        return None
    if metric in DYNAMIC:
        return None if duty_cycle else (
            f"'{metric}' is measured on the duty cycle; the study has no duty_cycle")
    if metric.startswith("payload@"):
        try:
            reach = float(metric[len("payload@"):])
        except ValueError:
            reach = math.nan
        return None if math.isfinite(reach) and reach >= 0 else (
            f"'{metric}': expected payload@R with R a reach in m, e.g. payload@3.0")
    if metric.startswith("holding:") and metric[len("holding:"):]:
        return None
    if metric.startswith("param:") and metric[len("param:"):]:
        return None
    known = [*STATIC, "payload@R", "holding:JOINT", "param:PATH", *DYNAMIC, *plugins]
    return f"unknown metric {metric!r}; expected one of {', '.join(known)}"
