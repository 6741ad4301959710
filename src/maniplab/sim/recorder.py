"""Recording a run in bounded memory: the C loop's buffers, emptied chunk by chunk into signals.

The run loop in C (``ml_plant_run``) writes its raw records (q, qd, the activations, commands,
modes, friction and limit forces, the end-effector's position) into :class:`Buffers` of one
chunk, :data:`CHUNK` steps at most; at each pause :func:`derive` turns those rows into the run's
signals, which go to a sink: :class:`Arrays`, the run's arrays allocated once for all samples, or
a run file (:class:`maniplab.sim.stream.RunWriter`). Recording a run in memory so costs its
stored arrays plus the fixed size of one chunk, whatever its duration; streamed, one chunk.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Protocol

import numpy as np

from maniplab.actuators.base import STANDARD_COMMANDS, STANDARD_STATES
from maniplab.sim import native

if TYPE_CHECKING:
    from maniplab.sim.plant import Plant

CHUNK = 20_000
"""Steps the C loop takes between two pauses (the progress bar moves, Ctrl-C is answered, the
buffers are emptied)."""

Layout = dict[str, tuple[np.dtype, tuple[int, ...]]]
"""A run's signals: name -> (dtype, shape of one sample), in the order :func:`derive` gives them."""


class Sink(Protocol):
    """Where the recorded samples go, in order, chunk by chunk."""

    def put(self, t: np.ndarray, signals: Mapping[str, np.ndarray]) -> None:
        """Take the next samples: times ``t`` (m,), s, and each signal (m, ...)."""


class Buffers:
    """The rows the C loop writes between two pauses.

    Args:
        n: joints.
        na: MuJoCo activations (``model.na``).
        rows: rows of each buffer (``CHUNK // every + 2`` holds one call's).
        plugin: the engine plugins' states (``model.npluginstate``) when they are recorded (the
            cylinders' energies), else 0.
    """

    def __init__(self, n: int, na: int, rows: int, plugin: int = 0) -> None:
        self.rows, self.na = rows, na
        self.arrays: dict[str, np.ndarray] = {"t": np.zeros(rows), "q": np.zeros((rows, n)), "qd": np.zeros((rows, n)),
                       "act": np.zeros((rows, max(na, 1))), "ctrl": np.zeros((rows, n)),
                       "mode": np.zeros((rows, n), np.int8), "fric": np.zeros((rows, n)),
                       "limit": np.zeros((rows, n)), "ee_pos": np.zeros((rows, 3))}
        if plugin:
            self.arrays["plugin"] = np.zeros((rows, plugin))

    @property
    def row_bytes(self) -> int:
        """The bytes of one row of all buffers."""
        return sum(a.itemsize * math.prod(a.shape[1:]) for a in self.arrays.values())

    def bind(self, run: native.RunStruct) -> None:
        """Point the C run's record at these buffers."""
        a = self.arrays
        run.t, run.q, run.qd = (native.pointer(a[k]) for k in ("t", "q", "qd"))
        run.act, run.ctrl = native.pointer(a["act"]), native.pointer(a["ctrl"])
        run.mode = native.pointer(a["mode"], ctypes.c_byte)
        run.fric, run.limit = native.pointer(a["fric"]), native.pointer(a["limit"])
        run.ee_pos = native.pointer(a["ee_pos"])
        if "plugin" in a:
            run.plugin_state = native.pointer(a["plugin"])

    def head(self, rows: int) -> dict[str, np.ndarray]:
        """The first ``rows`` rows of every buffer (views: valid until the loop runs on)."""
        out = {k: v[:rows] for k, v in self.arrays.items()}
        out["act"] = out["act"][:, : self.na]
        return out


def buffers(plant: Plant, rows: int) -> Buffers:
    """Buffers of ``rows`` rows for ``plant``'s runs (its plugin states when it has energies)."""
    plugin = plant.model.npluginstate if plant.energy else 0
    return Buffers(plant.n, plant.model.na, rows, plugin)


def derive(plant: Plant, raw: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The run's signals at m samples from the loop's raw records (:meth:`Buffers.head`).

    Returns:
        name -> array (m, n) (NaN at joints without the element; ``ee_pos`` (m, 3), ``mode``
        int8): q, qd, the standard states and the plugin ones, ctrl and each command, the
        actuators' outputs, tau_act, tau_fric (applied and viscous), tau_limit, mode, ee_pos.
        Some are views of ``raw``.
    """
    p = plant
    q, qd, ctrl, act = raw["q"], raw["qd"], raw["ctrl"], raw["act"]
    rows = len(q)
    out: dict[str, np.ndarray] = {"q": q, "qd": qd}
    out.update({name: np.full((rows, p.n), np.nan) for name in STANDARD_STATES})
    out.update(p.layout.read(act))
    out["ctrl"] = ctrl
    for name in dict.fromkeys((*STANDARD_COMMANDS, *(a.command for a in p.actuators))):
        mine = [a.command == name for a in p.actuators]
        out[name] = np.where(mine, ctrl, np.nan)
    out.update(p.actuator_outputs_at(q, act))
    out["tau_act"] = p.actuator_forces_at(q, qd, act, ctrl)
    out["tau_fric"] = raw["fric"] - p.viscous * qd  # applied + viscous at t_k
    out["tau_limit"] = raw["limit"]
    out["mode"] = raw["mode"]
    out["ee_pos"] = raw["ee_pos"]
    if p.energy:
        out.update(p.energy.read(raw["plugin"]))
    return out


def layout(plant: Plant) -> Layout:
    """The signals :func:`derive` gives for ``plant``: found by deriving one sample of its
    current state."""
    one = buffers(plant, 1)
    a = one.arrays
    state = plant.state()
    a["q"][0], a["qd"][0] = state.q, state.qd
    a["act"][0, : plant.model.na] = plant.data.act
    with np.errstate(all="ignore"):
        signals = derive(plant, one.head(1))
    return {name: (values.dtype, values.shape[1:]) for name, values in signals.items()}


def bytes_per_sample(signals: Layout) -> int:
    """Bytes of one sample of a run: its time (8) and every signal."""
    return 8 + sum(dtype.itemsize * math.prod(shape) for dtype, shape in signals.values())


def overhead(plant: Plant, per_sample: int) -> int:
    """The recorder's memory besides the run's arrays, at most, bytes: the loop's buffers, one
    chunk's signals and the temporaries that derive them (counted twice), and a chunk's inputs
    (for a sample every step; fewer samples take less)."""
    rows = CHUNK + 2
    return buffers(plant, 0).row_bytes * rows + 3 * per_sample * rows + \
        16 * plant.n * (CHUNK + 1)


class Arrays:
    """A run's arrays, allocated once for all its samples and filled chunk by chunk.

    Args:
        signals: the run's signals (:func:`layout`).
        rows: the samples of the run.
    """

    def __init__(self, signals: Layout, rows: int) -> None:
        self.t = np.empty(rows)
        self.signals = {name: np.empty((rows, *shape), dtype)
                        for name, (dtype, shape) in signals.items()}
        self.filled = 0

    def put(self, t: np.ndarray, signals: Mapping[str, np.ndarray]) -> None:
        """Copy the next samples in: times ``t`` (m,), s, and each signal (m, ...)."""
        start, stop = self.filled, self.filled + len(t)
        self.t[start:stop] = t
        for name, values in signals.items():
            self.signals[name][start:stop] = values
        self.filled = stop

    def complete(self) -> bool:
        """Whether every sample is in."""
        return self.filled == len(self.t)
