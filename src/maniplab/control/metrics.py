"""Tracking metrics of a closed-loop run and the validation table.

Errors are measured on the *plant's* end-effector (``run["ee_pos"]``, and the orientation from
the run's joint positions through the analytic model) against the reference trajectory, never on
the controller's own estimate.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from maniplab.control.kinematics import rotation_log
from maniplab.control.trajectory import Trajectory
from maniplab.model import AnalyticModel
from maniplab.sim.energy import energy_report
from maniplab.spec import model_of

#: Columns of the table: field -> (header, format).
COLUMNS: dict[str, tuple[str, str]] = {
    "label": ("case", "{}"),
    "rms_error_mm": ("RMS err [mm]", "{:.2f}"),
    "max_error_mm": ("max err [mm]", "{:.2f}"),
    "end_of_move_error_mm": ("end-of-move err [mm]", "{:.2f}"),
    "final_error_mm": ("final err [mm]", "{:.2f}"),
    "rms_orientation_mrad": ("RMS rot err [mrad]", "{:.2f}"),
    "peak_dP_MPa": ("peak |ΔP| [MPa]", "{:.2f}"),
    "peak_pressure_MPa": ("peak pressure [MPa]", "{:.2f}"),
    "peak_iv_A": ("peak |i_v| [A]", "{:.3f}"),
    "saturation_s": ("time at saturation [s]", "{:.3f}"),
    "pump_energy_kJ": ("pump energy [kJ]", "{:.2f}"),
}


@dataclasses.dataclass(frozen=True)
class TrackingMetrics:
    """How well a run followed its reference.

    Attributes:
        label: the case's name.
        rms_error_mm, max_error_mm: position error |p_d - p| over the move (t0 .. t0 + T), mm.
        end_of_move_error_mm: at the move's end (t0 + T), mm.
        final_error_mm: at the run's last sample, mm.
        rms_orientation_mrad: orientation error |log(R_d Rᵀ)| over the move, mrad (NaN when the
            reference does not turn and orientation was not controlled).
        peak_dP_MPa: largest |ΔP| over the run and the hydraulic joints, MPa (NaN: none).
        peak_dP_joint: the joint where it occurred.
        peak_iv_A: largest |i_v|, A (NaN: no hydraulic joint).
        saturation_s: total time with some command at its limit, s.
        window: (t0, t1) of the move, s.
        peak_pressure_MPa: largest pressure of any hydraulic joint, MPa: |ΔP| of a lumped
            cylinder, a chamber pressure pA or pB of a pinned one (NaN: none).
        peak_pressure_joint: the joint where it occurred, and which pressure ("dP", "pA", "pB").
        joints: per joint: its peak pressure (MPa, and which: "dP" or "pA/pB"; NaN without)
            and its peak |command| in its actuator's unit.
        pump_energy_kJ, losses_kJ: the energy the pump delivered through the pinned
            cylinders' valve sections over the run, and how much of it was lost
            (:mod:`maniplab.sim.energy`), kJ (NaN: no pinned cylinder).
    """

    label: str
    rms_error_mm: float
    max_error_mm: float
    end_of_move_error_mm: float
    final_error_mm: float
    rms_orientation_mrad: float
    peak_dP_MPa: float
    peak_dP_joint: str
    peak_iv_A: float
    saturation_s: float
    window: tuple[float, float]
    peak_pressure_MPa: float = math.nan
    peak_pressure_joint: str = ""
    joints: dict[str, dict[str, Any]] = dataclasses.field(default_factory=dict)
    pump_energy_kJ: float = math.nan
    losses_kJ: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-friendly dict (NaN written as None)."""
        return _plain(dataclasses.asdict(self))


def tracking_metrics(run: Any, trajectory: Trajectory, *, label: str | None = None,
                     orientation: bool | None = None,
                     model: AnalyticModel | None = None) -> TrackingMetrics:
    """Metrics of ``run`` (a ``ml.Run``) against ``trajectory``.

    Args:
        run: the closed-loop run (signals ee_pos, q, dP, iv, ctrl; on an arm whose tool hangs
            on passive joints, p_suspension, the point the move is of, instead of ee_pos).
        trajectory: the reference; its ``t0`` and ``duration`` define the move window.
        label: the case's name (default ``run.label``).
        orientation: measure the orientation error (default: when ``run.meta`` says the
            controller's task was "pose", or the reference turns).
        model: an analytic model of ``run.spec`` (built when needed).
    """
    t = np.asarray(run.t)
    ref_p = np.empty((len(t), 3))
    ref_R = np.empty((len(t), 3, 3))
    for k, tk in enumerate(t):
        r = trajectory.sample(float(tk))
        ref_p[k], ref_R[k] = r.position, r.rotation
    tracked = run["p_suspension"] if "p_suspension" in run else run["ee_pos"]
    err = np.linalg.norm(tracked - ref_p, axis=1)
    t0, t1 = float(trajectory.t0), float(trajectory.t0 + trajectory.duration)
    inside = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
    if not inside.any():
        inside = np.ones(len(t), dtype=bool)
    k1 = min(int(np.searchsorted(t, t1 - 1e-9)), len(t) - 1)
    task = (run.meta.get("control") or {}).get("task") if hasattr(run, "meta") else None
    if orientation is None:
        orientation = task == "pose" or not np.allclose(ref_R, ref_R[0], atol=1e-12)
    rot = math.nan
    if orientation:
        model = model or AnalyticModel(run.spec)
        R = model.fk(np.asarray(run.q)[inside])[:, :3, :3]
        angles = [np.linalg.norm(rotation_log(Rd @ Rk.T)) for Rd, Rk in zip(ref_R[inside], R)]
        rot = 1e3 * float(np.sqrt(np.mean(np.square(angles))))
    dP, iv = _hydraulic(run)
    peak_dP, joint = math.nan, ""
    if dP is not None and np.isfinite(dP).any():
        flat = np.nan_to_num(np.abs(dP), nan=-1.0)
        i = int(np.argmax(flat.max(axis=0)))
        peak_dP, joint = float(flat[:, i].max()) / 1e6, run.spec.joint_names[i]
    peak_iv = float(np.nanmax(np.abs(iv))) if iv is not None and np.isfinite(iv).any() else math.nan
    if not label:
        label = getattr(run, "label", "run")
    return TrackingMetrics(
        label=label,
        rms_error_mm=1e3 * float(np.sqrt(np.mean(err[inside] ** 2))),
        max_error_mm=1e3 * float(err[inside].max()),
        end_of_move_error_mm=1e3 * float(err[k1]),
        final_error_mm=1e3 * float(err[-1]),
        rms_orientation_mrad=rot,
        peak_dP_MPa=peak_dP, peak_dP_joint=joint, peak_iv_A=peak_iv,
        saturation_s=saturation_time(run), window=(t0, t1),
        **_pressures(run), **_energy(run),
    )


def _energy(run: Any) -> dict[str, Any]:
    """The pump's energy and the losses over the run, kJ (none without pinned cylinders)."""
    if "E_pump" not in getattr(run, "signals", {}):
        return {}
    report = energy_report(run)
    return {"pump_energy_kJ": report.pump / 1e3, "losses_kJ": report.losses / 1e3}


def _pressures(run: Any) -> dict[str, Any]:
    """The peak pressure over the joints (ΔP of lumped cylinders, chambers of pinned ones) and
    each joint's peak pressure and command."""
    names = run.spec.joint_names
    peaks = {k: np.nanmax(np.abs(np.asarray(run[k])), axis=0, initial=-1.0,
                          where=np.isfinite(np.asarray(run[k])))
             for k in ("dP", "pA", "pB") if k in run}
    ctrl = np.abs(np.asarray(run["ctrl"])) if "ctrl" in run else None
    joints: dict[str, dict[str, Any]] = {}
    best, where = math.nan, ""
    for j, (name, joint) in enumerate(zip(names, run.spec.joints)):
        mine = {k: float(v[j]) for k, v in peaks.items() if v[j] >= 0.0}
        label = "pA/pB" if "pA" in mine or "pB" in mine else ("dP" if mine else "")
        peak = max(mine.values()) / 1e6 if mine else math.nan
        joints[name] = {"peak_pressure_MPa": peak, "pressure": label,
                        "peak_command": float(ctrl[:, j].max()) if ctrl is not None else math.nan,
                        "command_unit": command_unit(joint)}
        if mine and not peak <= best:
            best, where = peak, f"{name} ({max(mine, key=mine.__getitem__)})"
    return {"peak_pressure_MPa": best, "peak_pressure_joint": where, "joints": joints}


def command_unit(joint: Any) -> str:
    """The unit of the joint's actuator command (\"\" when its plugin is not loaded)."""
    try:
        return model_of(joint).command_unit
    except Exception:  # noqa: BLE001 - a stored run's plugin that is not loaded: unit unknown
        return ""


def _hydraulic(run: Any) -> tuple[np.ndarray | None, np.ndarray | None]:
    dP = np.asarray(run["dP"]) if "dP" in run else None
    iv = np.asarray(run["iv"]) if "iv" in run else None
    return dP, iv


def saturation_time(run: Any) -> float:
    """Total time, s, during which some command (``run["ctrl"]``) sits at its limit.

    A sample's command is held until the next sample; a hydraulic joint saturates at its
    ``current_limit``, a torque joint at its ``limit`` (never when it has none).
    """
    ctrl = np.asarray(run["ctrl"])
    limit = np.array([np.inf if (lim := model_of(j).command_limit) is None else lim
                      for j in run.spec.joints])
    at = (np.abs(ctrl) >= limit * (1.0 - 1e-9)).any(axis=1)
    t = np.asarray(run.t)
    if len(t) < 2:
        return 0.0
    hold = np.diff(t)
    return float(hold[at[:-1]].sum())


def format_table(rows: Sequence[TrackingMetrics], columns: Sequence[str] | None = None) -> str:
    """A Markdown table of the metrics (one row per case)."""
    cols = list(columns or COLUMNS)
    header = [COLUMNS[c][0] for c in cols]
    body = []
    for row in rows:
        values = []
        for c in cols:
            v = getattr(row, c)
            values.append("–" if isinstance(v, float) and math.isnan(v) else COLUMNS[c][1].format(v))
        body.append(values)
    widths = [max(len(h), *(len(r[i]) for r in body)) if body else len(h)
              for i, h in enumerate(header)]
    line = lambda cells: "| " + " | ".join(c.ljust(w) for c, w in zip(cells, widths)) + " |"
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    return "\n".join([line(header), sep, *(line(r) for r in body)])


def to_json(rows: Sequence[TrackingMetrics]) -> str:
    """The metrics as a JSON list (NaN as null)."""
    return json.dumps([r.to_dict() for r in rows], indent=2)


def _plain(value: Any) -> Any:
    """NaN as None, through dicts and lists (JSON has no NaN)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return None if isinstance(value, float) and math.isnan(value) else value
