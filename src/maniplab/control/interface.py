"""The controller interface: what ``ml.simulate``, ``run_move``, sweeps and ``maniplab control``
ask of a controller, like a Simulink block or a python-control system.

A controller is an object with

- ``dt``: its sample time, s (None: every step of the plant); the run calls it at each multiple
  of ``dt`` and holds its command in between (zero-order hold);
- ``reset(state)``: called by every run before its first sample, with the plant's state then
  (:class:`~maniplab.sim.state.PlantState`), so that nothing carries over from an earlier run;
- ``output(t, state)``: the commands at sample time t, an array (n,) or a mapping joint ->
  command (valve current A, force N, torque N·m, or a plugin's command);
- ``log_signals``: the signals it logs, name -> (description, unit), recorded in the run with
  their units (:meth:`Controller.log` inside ``output``);
- ``reference`` (optional): the Cartesian reference it tracks (a
  :class:`~maniplab.control.trajectory.Trajectory`), and ``tolerances`` (final, RMS error, mm):
  the run's health verdict then includes tracking against them, so a run that ends far from its
  target is never "ok".

Subclass :class:`Controller` and write ``output`` (and ``reset`` when it has state); the base
keeps the log and adds it, with the reference, to the run. A plain function ``f(t, state)``
still works as a controller: it has no reset, log or reference.
"""

from __future__ import annotations

import abc
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

import numpy as np

from maniplab.control.trajectory import Trajectory

TOLERANCES = (2.0, 5.0)
"""The default tolerances of a move, mm: the final position error and the RMS error over the
move (``maniplab control --tolerance``)."""


class Controller(abc.ABC):
    """Base class of a controller (see the module's text for the interface).

    Attributes:
        dt: sample time, s (None: every plant step).
        log_signals: the signals :meth:`log` records, name -> (description, unit).
        reference: the Cartesian reference tracked, or None.
        tolerances: (final, RMS) position error allowed, mm, when there is a reference.
    """

    dt: float | None = None
    log_signals: Mapping[str, tuple[str, str]] = MappingProxyType({})
    reference: Trajectory | None = None
    tolerances: tuple[float, float] = TOLERANCES

    def reset(self, state: Any = None) -> None:
        """Forget everything of an earlier run (the base: the log). Override to clear your own
        states too, and call ``super().reset(state)``."""
        self._log_t: list[float] = []
        self._log_rows: dict[str, list[np.ndarray]] = {k: [] for k in self.log_signals}
        self._t = 0.0

    @abc.abstractmethod
    def output(self, t: float, state: Any) -> Any:
        """The commands at sample time ``t``, s, for the plant ``state``: (n,) or a mapping."""

    def __call__(self, t: float, state: Any) -> Any:
        if not hasattr(self, "_log_t"):
            self.reset(state)
        self._t = t
        return self.output(t, state)

    def log(self, **values: Any) -> None:
        """Record this sample's values of declared signals (arrays or numbers), from ``output``.

        Raises:
            KeyError: a name not in :attr:`log_signals`.
        """
        if not hasattr(self, "_log_t"):
            self.reset()
        unknown = sorted(set(values) - set(self.log_signals))
        if unknown:
            raise KeyError(f"signals {unknown} are not declared in log_signals "
                           f"({sorted(self.log_signals)})")
        if not self._log_t or self._log_t[-1] != self._t:
            self._log_t.append(self._t)
            for rows in self._log_rows.values():
                rows.append(np.array([np.nan]))
        for name, value in values.items():
            self._log_rows[name][-1] = np.atleast_1d(np.asarray(value, dtype=float)).copy()

    def signals(self) -> dict[str, np.ndarray]:
        """The logged samples, name -> (K, width); ``"t"`` the sample times, s, (K,)."""
        if not hasattr(self, "_log_t"):
            self.reset()
        out = {"t": np.asarray(self._log_t, dtype=float)}
        for name, rows in self._log_rows.items():
            width = max((r.size for r in rows), default=1)
            out[name] = np.array([np.broadcast_to(r, (width,)) for r in rows]).reshape(-1, width)
        return out

    def annotate(self, run: Any) -> Any:
        """The run with the logged signals (zero-order hold onto ``run.t``, NaN before the first
        sample), their units, and the reference's ``p_ref`` and tolerances added."""
        logged = self.signals()
        times = logged.pop("t")
        extra = {name: hold(times, values, run.t) for name, values in logged.items()}
        units = {name: unit for name, (_, unit) in self.log_signals.items()}
        return with_reference(run, self.reference, self.tolerances, extra, units)


def hold(times: np.ndarray, values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``values`` (K, w) sampled at ``times`` (K,), held onto ``t`` (N,): (N, w), NaN before
    the first sample."""
    t = np.asarray(t, dtype=float)
    width = values.shape[1] if values.ndim == 2 else 1
    if len(times) == 0:
        return np.full((len(t), width), np.nan)
    idx = np.searchsorted(times, t + 1e-12, side="right") - 1
    out = np.asarray(values, dtype=float).reshape(len(times), width)[np.clip(idx, 0, None)].copy()
    out[idx < 0] = np.nan
    return out


def with_reference(run: Any, reference: Trajectory | None, tolerances: tuple[float, float],
                   extra: dict[str, np.ndarray], units: dict[str, str]) -> Any:
    """A new run of ``run``'s type with signals ``extra`` (units ``units``) and, when there is
    a reference, ``p_ref`` (its position at every sample, m) and ``meta["reference"]`` (the
    move's window and the tolerances the health verdict checks, mm)."""
    meta = dict(run.meta)
    extra = dict(extra)
    units = dict(units)
    if reference is not None:
        extra["p_ref"] = np.array([reference.sample(float(tk)).position for tk in run.t])
        units["p_ref"] = "m"
        final, rms = (float(x) for x in tolerances)
        meta["reference"] = {"t0": float(reference.t0),
                             "t1": float(reference.t0 + reference.duration),
                             "final_mm": final, "rms_mm": rms}
    clash = sorted(set(extra) & set(run.signals))
    if clash:
        raise ValueError(f"the run already has signals {clash}")
    meta["units"] = {**dict(meta.get("units") or {}), **units}
    return type(run)(t=run.t, signals={**run.signals, **extra}, spec=run.spec, meta=meta)
