"""The cascade's sample in C (``maniplab_native/cascade.h``): ctypes bindings, the C state of one
:class:`~maniplab.control.cascade.CascadeController`, its log, and the native controller the
plant's run loop calls with no Python.

:class:`CompiledCascade` copies the controller's settings (gains, the model's kernels, each
joint's drive) into an ``ml_cascade`` and owns the log buffers the C code writes one row per
sample into; :class:`NativeController` is a run's schedule (sample times, the reference sampled
at them) around it, with the address of ``ml_cascade_control`` (plant.h's ``ml_controller_fn``).
"""

from __future__ import annotations

import ctypes
import weakref
from collections.abc import Sequence
from ctypes import POINTER, c_double, c_int, c_void_p
from typing import Any

import numpy as np

from maniplab.actuators import ForceDrive
from maniplab.actuators.hydraulic import chambers
from maniplab.clib import Functions
from maniplab.control.errors import ControlError

MODES = {"cascade": 0, "pid": 1}
"""``ML_MODE_*``."""

DRIVES = {"valve": 0, "force": 1, "chambers": 3}
"""``ML_DRIVE_*`` of the compiled drives' kinds (:class:`~maniplab.actuators.drive.CompiledDrive`)."""

PYTHON = 2
"""``ML_DRIVE_PYTHON``: a joint whose drive Python runs."""

REF_SIZE = 24
"""Doubles of one reference sample: p_d (3), R_d (3x3 row-major), twist (6), accel (6)."""

AUX_TAU, AUX_QD_REF, AUX_SPEED, AUX_INERTIA = range(4)
"""Rows of the sample's output for the Python drives (``ML_AUX_*``)."""

STATUS = {
    1: "the controller's log is full",
    2: "the run loop called the controller at a time it was not scheduled for",
    3: "a command came out NaN or infinite",
    4: "a joint's drive runs in Python",
}
"""``ML_CASCADE_*`` statuses of a native run, by code."""

LOG_FIELDS = {"t": 1, "x_d": 12, "x": 12, "e": 6, "a_x": 6, "qdd": 0, "tau": 0, "dP_d": 0,
              "phi": 0, "cmd": 0}
"""The log's buffers and their widths (0: one per joint), in ``ml_cascade_log``'s order."""


class PidGains(ctypes.Structure):
    """``ml_pid_gains``."""

    _fields_ = [("kp", c_void_p), ("ki", c_void_p), ("kd", c_void_p), ("lo", c_void_p),
                ("hi", c_void_p), ("tracking", c_void_p), ("limited", c_int),
                ("filter_a", c_double), ("filter_b", c_double)]


class Config(ctypes.Structure):
    """``ml_cascade_config``."""

    _fields_ = [
        ("n", c_int), ("rows", c_int), ("mode", c_int), ("nparams", c_int), ("params", c_void_p),
        ("fk", c_void_p), ("jacobian", c_void_p), ("mass", c_void_p), ("mass_bias", c_void_p),
        ("dt", c_double), ("fd_step", c_double), ("outer", PidGains),
        ("dls_damping", c_double), ("dls_threshold", c_double), ("weights", c_void_p),
        ("null_damping", c_double), ("viscous", c_void_p), ("coulomb", c_void_p),
        ("stribeck", c_void_p), ("joint", PidGains), ("velocity_gain", c_double),
        ("drive", c_void_p), ("limit", c_void_p), ("area", c_void_p), ("valve_gain", c_void_p),
        ("supply", c_void_p), ("orifice", c_void_p), ("capacitance", c_void_p),
        ("leakage", c_void_p), ("pressure_kp", c_void_p), ("pressure_ki", c_void_p),
        ("min_root", c_double), ("rate_alpha", c_double), ("speed_gain", c_double),
        ("compressibility", c_int), ("chambers", c_void_p), ("geometry", c_void_p),
        ("prismatic", c_void_p), ("weight", c_void_p),
    ]


class LogStruct(ctypes.Structure):
    """``ml_cascade_log``."""

    _fields_ = [("capacity", c_int), ("count", c_int),
                *((name, c_void_p) for name in LOG_FIELDS)]


class RunStruct(ctypes.Structure):
    """``ml_cascade_run``."""

    _fields_ = [("cascade", c_void_p), ("count", c_int), ("next", c_int), ("times", c_void_p),
                ("refs", c_void_p), ("status", c_int), ("postures", c_void_p)]


_P = c_void_p
_C = Functions({
    "ml_cascade_sizes": (c_int, [POINTER(c_int)]),
    "ml_cascade_new": (c_void_p, [POINTER(Config)]),
    "ml_cascade_free": (None, [_P]),
    "ml_cascade_reset": (None, [_P]),
    "ml_cascade_set_log": (None, [_P, POINTER(LogStruct)]),
    "ml_cascade_sample": (c_int, [_P, c_double, _P, _P, _P, _P, _P, _P, _P, _P]),
    "ml_cascade_commit": (None, [_P, _P]),
    "ml_cascade_control": (c_int, [_P, c_double, _P, _P, _P]),
})
"""The compiled cascade's C functions (``maniplab_native/cascade.c``)."""


def check_layout() -> None:
    """Raise when the ctypes mirrors differ in size from the C structures (a stale mirror)."""
    sizes = (c_int * 4)()
    _C().ml_cascade_sizes(sizes)
    mirrors = (PidGains, Config, LogStruct, RunStruct)
    if list(sizes) != [ctypes.sizeof(s) for s in mirrors]:
        raise ControlError(f"maniplab's compiled cascade does not match its ctypes mirrors: "
                           f"C sizes {list(sizes)}, Python {[ctypes.sizeof(s) for s in mirrors]}")


def pack_reference(ref: Any, out: np.ndarray) -> None:
    """Write a :class:`~maniplab.control.trajectory.Reference` into ``out`` (REF_SIZE,)."""
    out[0:3] = ref.position
    out[3:12] = np.asarray(ref.rotation).reshape(9)
    out[12:18] = ref.twist
    out[18:24] = ref.accel


class _Keeper:
    """Arrays a C structure points into, kept alive with it: ``keeper.put(values) -> address``."""

    def __init__(self) -> None:
        self.arrays: list[np.ndarray] = []

    def put(self, values: Any, dtype: Any = np.float64) -> int:
        array = np.ascontiguousarray(values, dtype=dtype).ravel().copy()
        if array.size == 0:
            array = np.zeros(1, dtype=dtype)
        self.arrays.append(array)
        return int(array.ctypes.data)

    def optional(self, values: Any) -> int | None:
        return None if values is None else self.put(values)


def _pid_gains(pid: Any, keeper: _Keeper) -> PidGains:
    """``ml_pid_gains`` of a :class:`~maniplab.control.pid.PID`: its gains, limits, filter."""
    limited = bool(pid._limited)
    return PidGains(kp=keeper.put(pid.kp), ki=keeper.put(pid.ki), kd=keeper.put(pid.kd),
                    lo=keeper.put(pid.lo) if limited else None,
                    hi=keeper.put(pid.hi) if limited else None,
                    tracking=keeper.put(pid.tracking_time) if limited else None,
                    limited=int(limited), filter_a=pid._a, filter_b=pid._b)


def _drive_parameters(drives: Sequence[ForceDrive], n: int
                      ) -> tuple[np.ndarray, dict[str, Any], list[ForceDrive]]:
    """Each joint's ``ML_DRIVE_*``, the valves' parameters over all joints (n each, or scalars),
    and the drives Python runs."""
    kinds = np.full(n, PYTHON, dtype=np.intc)
    values: dict[str, Any] = {name: np.zeros(n) for name in (
        "area", "valve_gain", "capacitance", "leakage", "pressure_kp", "pressure_ki")}
    values.update(supply=np.ones(n), orifice=np.ones(n, dtype=np.intc), min_root=0.05,
                  rate_alpha=1.0, speed_gain=0.0, compressibility=1,
                  chambers=[chambers.ChambersLaw() for _ in range(n)],
                  geometry=np.zeros((n, 3)), prismatic=np.zeros(n, dtype=np.intc))
    python = []
    for drive in drives:
        compiled = drive.compiled()
        if compiled is None or compiled.kind not in DRIVES:
            python.append(drive)
            continue
        kinds[drive.joints] = DRIVES[compiled.kind]
        for name, value in compiled.parameters.items():
            if name == "chambers":  # one law per joint (ctypes structures)
                for j, law in zip(drive.joints, value):
                    values[name][j] = law
            elif np.ndim(value) == 0:
                values[name] = value
            else:
                values[name][drive.joints] = value
    return kinds, values, python


def _pinned(values: dict[str, Any], kinds: np.ndarray, keeper: _Keeper) -> dict[str, Any]:
    """The pinned cylinders' laws, pin geometry and joint kinds for ``ml_cascade_config`` (all
    None when no joint has one)."""
    if not (kinds == DRIVES["chambers"]).any():
        return {"chambers": None, "geometry": None, "prismatic": None}
    laws = (chambers.ChambersLaw * len(kinds))(*values["chambers"])
    keeper.arrays.append(laws)  # type: ignore[arg-type]
    return {"chambers": ctypes.addressof(laws), "geometry": keeper.put(values["geometry"]),
            "prismatic": keeper.put(values["prismatic"], np.intc)}


class CompiledCascade:
    """The C state (``ml_cascade``) of one cascade controller, and its log.

    Args:
        controller: the :class:`~maniplab.control.cascade.CascadeController` whose blocks give
            every setting (its outer and joint PIDs, G1, the model's kernels, the drives).

    Attributes:
        python: the drives Python runs (their joints get NaN from C).
        log: the log's buffers by ``LOG_FIELDS`` name, each (capacity, width).
    """

    def __init__(self, controller: Any) -> None:
        check_layout()
        c = controller
        self.n = n = c.n
        self.rows = len(c.rows)
        keeper = _Keeper()
        kinds, valves, self.python = _drive_parameters(c.drives, n)
        self.kinds = kinds
        """Each joint's ``ML_DRIVE_*``, (n,)."""
        model = c.model
        g1, gains = c.g1, c.gains
        config = Config(
            n=n, rows=self.rows, mode=MODES[c.mode], nparams=model.params.size,
            params=keeper.put(model.params),
            fk=model.kernel_address("fk"), jacobian=model.kernel_address("jacobian"),
            mass=model.kernel_address("M"), mass_bias=model.kernel_address("mass_bias"),
            dt=c.dt, fd_step=c.kin.fd_step, outer=_pid_gains(c.outer, keeper),
            dls_damping=gains.dls_damping, dls_threshold=gains.dls_threshold,
            weights=keeper.optional(c.weights),
            null_damping=gains.null_damping if c._redundant else 0.0,
            viscous=keeper.put(g1.fv), coulomb=keeper.put(g1.fc) if g1.fc.any() else None,
            stribeck=keeper.put(g1.vs), joint=_pid_gains(c.joint_pid, keeper),
            velocity_gain=c._velocity_gain, drive=keeper.put(kinds, np.intc),
            limit=keeper.put(c._limit),
            orifice=keeper.put(valves.pop("orifice"), np.intc),
            **{name: keeper.put(valves.pop(name)) for name in (
                "area", "valve_gain", "supply", "capacitance", "leakage", "pressure_kp",
                "pressure_ki")},
            min_root=float(valves["min_root"]), rate_alpha=float(valves["rate_alpha"]),
            speed_gain=float(valves["speed_gain"]),
            compressibility=int(bool(valves["compressibility"])),
            weight=keeper.optional(g1.weight), **_pinned(valves, kinds, keeper))
        address = _C().ml_cascade_new(ctypes.byref(config))
        if not address:
            raise ControlError("maniplab's compiled cascade could not be made (out of memory)")
        self.address: int = address
        self._finalizer = weakref.finalize(self, _C().ml_cascade_free, address)
        # per-sample buffers of the Python path
        self._ref = np.zeros(REF_SIZE)
        self._q, self._qd, self._dP, self._pB = (np.zeros(n) for _ in range(4))
        self._posture = np.zeros(2 * n)
        self.aux = np.zeros((4, n))
        self._addresses = [int(a.ctypes.data)
                           for a in (self._ref, self._q, self._qd, self._dP, self._pB)]
        self._logstruct = LogStruct()
        self.log: dict[str, np.ndarray] = {}
        self.reserve(64)
        _C().ml_cascade_set_log(address, ctypes.byref(self._logstruct))

    @property
    def count(self) -> int:
        """Rows in the log (samples since the reset)."""
        return int(self._logstruct.count)

    def reserve(self, rows: int) -> None:
        """Make room for ``rows`` more samples in the log (buffers grow, rows kept)."""
        need = self.count + rows
        capacity = self._logstruct.capacity
        if need <= capacity:
            return
        capacity = max(need, 2 * capacity)
        count = self.count
        for name, width in LOG_FIELDS.items():
            shape = (capacity,) if width == 1 else (capacity, width or self.n)
            array = np.full(shape, np.nan)
            if name in self.log:
                array[:count] = self.log[name][:count]
            self.log[name] = array
            setattr(self._logstruct, name, int(array.ctypes.data))
        self._logstruct.capacity = capacity

    def reset(self) -> None:
        """Clear the loops' states and the log (``ml_cascade_reset``)."""
        _C().ml_cascade_reset(self.address)

    def sample(self, t: float, ref: Any, q: np.ndarray, qd: np.ndarray,
               dP: np.ndarray | None, pB: np.ndarray | None = None,
               posture: np.ndarray | None = None) -> np.ndarray:
        """One sample up to the commands (NaN at the Python drives' joints), (n,); the Python
        drives' inputs are then in :attr:`aux`. Call :meth:`commit` with the whole command.

        ``dP`` holds a lumped cylinder's ΔP and a pinned one's pA, ``pB`` a pinned one's rod
        side (Pa, (n,) each); ``posture`` the planned joint path's q and q̇ at t, (2n,), or
        None."""
        self.reserve(1)
        pack_reference(ref, self._ref)
        self._q[:] = q
        self._qd[:] = qd
        self._dP[:] = 0.0 if dP is None else dP
        self._pB[:] = 0.0 if pB is None else pB
        if posture is not None:
            self._posture[:] = posture
        cmd = np.empty(self.n)
        _C().ml_cascade_sample(self.address, t, *self._addresses,
                              None if posture is None else self._posture.ctypes.data,
                              cmd.ctypes.data, self.aux.ctypes.data)
        return cmd

    def commit(self, cmd: np.ndarray) -> None:
        """Finish the sample with the whole command (n,): saturation flag and log row."""
        cmd = np.ascontiguousarray(cmd, dtype=float)
        _C().ml_cascade_commit(self.address, cmd.ctypes.data)

    def rows_of(self, name: str) -> np.ndarray:
        """The logged rows of one buffer (a copy), (count, width) or (count,) for ``t``."""
        return self.log[name][:self.count].copy()


class NativeController:
    """A cascade controller as a C function for the plant's run loop: ``function(context, t, m,
    d, u)`` (plant.h's ``ml_controller_fn``) writes the commands of the sample at t.

    It runs with no Python (the loop may release the GIL), writes the controller's log (so the
    controller's ``signals()`` and ``annotate()`` show its samples), and returns non-zero (see
    :attr:`status`, :meth:`message`) on a non-finite command or a call off its schedule.

    Args:
        cascade: the controller's C state.
        times: the sample times the loop calls it at, s, ascending, (K,).
        refs: the reference at those times, (K, REF_SIZE).
        postures: the planned joint path (q, q̇) at those times, (K, 2n), or None.

    Attributes:
        function: the address of ``ml_cascade_control``.
        context: the address of this run's ``ml_cascade_run`` (kept alive with this object).
        times: the sample times, s, (K,).
    """

    def __init__(self, cascade: CompiledCascade, times: np.ndarray, refs: np.ndarray,
                 postures: np.ndarray | None = None) -> None:
        self.cascade = cascade
        self.times = np.ascontiguousarray(times, dtype=float)
        self._refs = np.ascontiguousarray(refs, dtype=float)
        self._postures = (None if postures is None
                          else np.ascontiguousarray(postures, dtype=float))
        self._run = RunStruct(cascade=cascade.address, count=len(self.times), next=0,
                              times=int(self.times.ctypes.data),
                              refs=int(self._refs.ctypes.data), status=0,
                              postures=None if self._postures is None
                              else int(self._postures.ctypes.data))
        self.function: int = _C.address("ml_cascade_control")
        self.context: int = ctypes.addressof(self._run)

    @property
    def status(self) -> int:
        """The last failed call's ``ML_CASCADE_*`` status, 0 when none failed."""
        return int(self._run.status)

    @property
    def samples(self) -> int:
        """Samples of the schedule called so far (the next one expected)."""
        return int(self._run.next)

    def message(self) -> str | None:
        """What went wrong, one line, or None."""
        if not self.status:
            return None
        k = max(self.samples - 1, 0)
        when = f" (sample {k} of {len(self.times)}, t = {self.times[k]:.6g} s)" if len(
            self.times) else ""
        return f"the compiled cascade: {STATUS.get(self.status, f'status {self.status}')}{when}"
