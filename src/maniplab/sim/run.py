"""The result of a simulation: time, joint states and named signals, with the spec that made them."""

from __future__ import annotations

import dataclasses
import functools
import os
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from maniplab.errors import ManiplabError
from maniplab.sim import store
from maniplab.sim.energy import SIGNALS as ENERGY_SIGNALS
from maniplab.sim.energy import SUPPLY_INTEGRAL
from maniplab.sim.health import Health, assess
from maniplab.sim.store import RunFileError

__all__ = ["UNITS", "Run", "RunFileError", "RunShapeError"]
from maniplab.spec import ManipulatorSpec

#: Units of the standard signals ("joint" means rad for R joints and m for P joints).
UNITS: dict[str, str] = {
    "q": "rad | m", "qd": "rad/s | m/s", "qdd": "rad/s² | m/s²",
    "tau_act": "N·m | N", "tau_fric": "N·m | N", "dP": "Pa", "Q": "m³/s", "iv": "A",
    "mode": "FrictionMode", "ee_pos": "m", "ctrl": "A | N·m | N",
    "tau_limit": "N·m | N", "z": "rad | m", "pA": "Pa", "pB": "Pa", "spool": "",
    "stroke": "m", "cylinder_force": "N", "hold_a": "", "hold_b": "",
    **{name: "J" for name in ENERGY_SIGNALS}, SUPPLY_INTEGRAL: "Pa·s",
}


class RunShapeError(ManiplabError, ValueError):
    """A run's signals do not have one sample per time.

    It is also a ValueError, which :class:`Run` raised before.
    """


@dataclasses.dataclass(frozen=True, eq=False)
class Run:
    """Sampled trajectory of one simulation.

    Attributes:
        t: sample times, s, shape (N,).
        signals: name -> array of shape (N, n) per joint (NaN where a joint has no such element,
            e.g. ΔP of a torque joint), or (N, k) for other signals (``ee_pos`` is (N, 3)).
            Standard names: q, qd, tau_act, tau_fric, dP, Q, iv, mode, ee_pos (see ``UNITS``).
        spec: the spec simulated, with every override applied.
        meta: how the run was made (overrides, inputs, controller, dt, integrator, versions...),
            JSON-serialisable.
    """

    t: np.ndarray
    signals: Mapping[str, np.ndarray]
    spec: ManipulatorSpec
    meta: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        if np.ndim(self.t) != 1:
            raise RunShapeError(f"t must be one-dimensional, not of shape {np.shape(self.t)}")
        n = len(self.t)
        for name, values in self.signals.items():
            samples = len(values) if np.ndim(values) else 0
            if samples != n:
                raise RunShapeError(f"signal {name!r} has {samples} samples, t has {n}")

    @property
    def q(self) -> np.ndarray:
        """Joint positions, rad or m, shape (N, n)."""
        return self.signals["q"]

    @property
    def qd(self) -> np.ndarray:
        """Joint velocities, rad/s or m/s, shape (N, n)."""
        return self.signals["qd"]

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.signals[name]
        except KeyError:
            raise KeyError(f"run has no signal {name!r}; it has {', '.join(self.signals)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self.signals

    def __iter__(self) -> Iterator[str]:
        return iter(self.signals)

    @property
    def label(self) -> str:
        """A short name for legends: the run's ``meta['label']`` or the spec's name."""
        return str(self.meta.get("label", self.spec.name))

    @functools.cached_property
    def health(self) -> Health:
        """The run's health verdict, computed from its signals (:mod:`~maniplab.sim.health`)."""
        return assess(self)

    def units(self) -> dict[str, str]:
        """The units of the run's signals, name -> unit: the standard ones (see ``UNITS``) and
        those a controller declared (``meta["units"]``)."""
        declared = {**UNITS, **(self.meta.get("units") or {})}
        return {k: str(declared[k]) for k in self.signals if k in declared}

    def save(self, path: str | os.PathLike[str], *, compress: bool = False) -> None:
        """Write the run to ``path`` (.npz) atomically; :meth:`load` reads it back bit for bit.
        ``compress``: deflate the arrays (about 0.4 of the size; read whole, not mapped)."""
        store.save(self, Path(path), compress)

    @classmethod
    def load(cls, path: str | os.PathLike[str], *, mmap: bool = False) -> Run:
        """Read a run written by :meth:`save` (or streamed by ``simulate(stream=...)``); raises
        RunFileError when it cannot.

        Args:
            path: the run file (.npz).
            mmap: memory-map the arrays instead of reading them (read-only; their pages are read
                from the file when used, so a run larger than the memory can be looked at).
        """
        return store.load(Path(path), cls, mmap=mmap)
