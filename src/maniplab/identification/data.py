"""Measured experiments: the inputs applied to a real arm and what was measured, from CSV or runs.

A CSV file has a header row and one row per sample::

    t,ctrl.q1,ctrl.q2,q.q1,q.q2,dP.q1,dP.q2
    0.000,0.0,0.0,-0.1800,1.2700,1.02e6,4.98e6
    0.002,0.1,0.0,-0.1800,1.2700,1.05e6,4.98e6
    ...

``t`` is the time (s, increasing, any start, any rate); every other column is
``<signal>.<joint>``: ``ctrl`` the command applied (valve current in A, or force/torque), and the
measured ``q`` (rad or m), ``qd`` (rad/s or m/s), ``dP``, ``pA``, ``pB`` (Pa) and ``stroke`` (m: a
pinned cylinder's piston travel from fully retracted, as a length transducer in the cylinder
reads it); ``q`` or ``stroke`` is required for at least one joint. A joint without a ``ctrl``
column gets 0 (a closed valve, no force). An optional ``supply`` column (no joint) is the supply
pressure measured at the pump (Pa): the simulations feed the pinned cylinders' valves at it
instead of at the pump's model. A maniplab run file (.npz) is read the same way: its ``ctrl`` as
the inputs, its q, qd, pressures and strokes as measured.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from maniplab.errors import ManiplabError
from maniplab.spec import ManipulatorSpec

if TYPE_CHECKING:
    from maniplab.sim.signals import Signal

INPUT = "ctrl"
SUPPLY = "supply"
"""The column of a measured supply pressure, Pa."""
MEASURABLE = ("q", "qd", "dP", "pA", "pB", "stroke")
"""The signals a fit compares, in the order residuals are stacked."""


class DataError(ManiplabError):
    """A measurement file that cannot be used: one line naming the file, line and column."""


@dataclasses.dataclass(frozen=True)
class Experiment:
    """One experiment on the arm.

    Attributes:
        name: where it came from (the file's name).
        t: sample times from the experiment's start, s, (N,).
        inputs: joint name -> the command at each sample, (N,) (held until the next sample).
        measured: (signal, joint name) -> the measured values, (N,).
        supply: the supply pressure measured at each sample, Pa, (N,), or None.
    """

    name: str
    t: np.ndarray
    inputs: dict[str, np.ndarray]
    measured: dict[tuple[str, str], np.ndarray]
    supply: np.ndarray | None = None

    @property
    def duration(self) -> float:
        return float(self.t[-1])


def load_experiments(paths: Iterable[str | os.PathLike[str]], spec: ManipulatorSpec,
                     signals: Iterable[str] | None = None) -> list[Experiment]:
    """Every file as an experiment (CSV or run file), keeping the measured ``signals`` (default:
    all of :data:`MEASURABLE` the file has).

    Raises:
        DataError: a file is missing, unreadable or malformed (one line).
    """
    keep = _signals(signals)
    return [load_experiment(path, spec, keep) for path in paths]


def load_experiment(path: str | os.PathLike[str], spec: ManipulatorSpec,
                    signals: tuple[str, ...] = MEASURABLE) -> Experiment:
    """One file as an experiment (see :func:`load_experiments`)."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    if path.suffix == ".npz":
        return _from_run(path, spec, signals)
    return _from_csv(path, spec, signals)


def _signals(signals: Iterable[str] | None) -> tuple[str, ...]:
    if signals is None:
        return MEASURABLE
    keep = tuple(signals)
    unknown = [s for s in keep if s not in MEASURABLE]
    if unknown:
        raise DataError(f"unknown measured signal(s) {', '.join(unknown)}; expected some of "
                        f"{', '.join(MEASURABLE)}")
    if "q" not in keep and "stroke" not in keep:
        raise DataError("the measured signals must include q or stroke")
    return keep


def _from_csv(path: Path, spec: ManipulatorSpec, signals: tuple[str, ...]) -> Experiment:
    try:
        with path.open(newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(f"{path}: cannot read it ({e})") from None
    if len(rows) < 3:
        raise DataError(f"{path}: needs a header row and at least two samples")
    header = [h.strip() for h in rows[0]]
    columns = [_column(path, h, spec) for h in header]
    if "t" not in header:
        raise DataError(f"{path}: no column 't' (the time, s)")
    values = np.empty((len(rows) - 1, len(header)))
    for i, row in enumerate(rows[1:]):
        if len(row) != len(header):
            raise DataError(f"{path} line {i + 2}: {len(row)} values for {len(header)} columns")
        for k, text in enumerate(row):
            values[i, k] = _number(path, i + 2, header[k], text)
    t = values[:, header.index("t")]
    _check_time(path, t)
    inputs, measured = {}, {}
    supply = values[:, header.index(SUPPLY)] if SUPPLY in header else None
    for (signal, joint), column in zip(columns, values.T):
        if signal == INPUT:
            inputs[joint] = column
        elif signal in signals:
            measured[(signal, joint)] = column
    if supply is not None:
        _check_supply(path, supply)
    return dataclasses.replace(_experiment(path, spec, t - t[0], inputs, measured), supply=supply)


def _check_supply(path: Path, supply: np.ndarray) -> None:
    """A measured supply pressure is positive at every sample (Pa)."""
    if not np.all(supply > 0.0):
        k = int(np.argmax(~(supply > 0.0)))
        raise DataError(f"{path} line {k + 2}, column 'supply': {supply[k]:.6g} Pa (a measured "
                        "supply pressure is a positive number of pascals)")


def load_supply(path: Path) -> Signal:
    """The ``supply`` column of a measurement CSV (columns ``t`` and ``supply``, others ignored)
    as a signal held at its samples (Pa), its time from the file's first sample.

    Raises:
        DataError: the file cannot be read, has no such columns, or a bad value (one line).
    """
    from maniplab.sim.signals import held

    try:
        with path.open(newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(f"{path}: cannot read it ({e})") from None
    header = [h.strip() for h in rows[0]] if rows else []
    if "t" not in header or SUPPLY not in header or len(rows) < 3:
        raise DataError(f"{path}: needs a header row with columns 't' and 'supply' (Pa) and at "
                        "least two samples")
    it, ip = header.index("t"), header.index(SUPPLY)
    t = np.array([_number(path, i + 2, "t", r[it]) for i, r in enumerate(rows[1:])])
    p = np.array([_number(path, i + 2, SUPPLY, r[ip]) for i, r in enumerate(rows[1:])])
    _check_time(path, t)
    _check_supply(path, p)
    return held(t - t[0], p)


def _column(path: Path, name: str, spec: ManipulatorSpec) -> tuple[str, str]:
    if name in ("t", SUPPLY):
        return (name, "")
    signal, _, joint = name.partition(".")
    if signal not in (INPUT, *MEASURABLE) or not joint:
        raise DataError(f"{path}: column {name!r} is not t, supply or <signal>.<joint> with "
                        f"signal one of {', '.join((INPUT, *MEASURABLE))}")
    if joint not in spec.joint_names:
        raise DataError(f"{path}: column {name!r}: no joint {joint!r} in {spec.name} (joints: "
                        f"{', '.join(spec.joint_names)})")
    return (signal, joint)


def _number(path: Path, line: int, column: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise DataError(f"{path} line {line}, column {column!r}: {text.strip()!r} is not a "
                        "number") from None
    if not math.isfinite(value):
        raise DataError(f"{path} line {line}, column {column!r}: {text.strip()} (every value must "
                        "be finite: drop or fill the sample)")
    return value


def _check_time(path: Path, t: np.ndarray, line_offset: int = 2) -> None:
    steps = np.diff(t)
    if np.any(steps <= 0.0):
        k = int(np.argmax(steps <= 0.0)) + 1
        raise DataError(f"{path} line {k + line_offset}: time {t[k]:.6g} s is not after the "
                        f"previous sample's {t[k - 1]:.6g} s (time must increase)")


def _from_run(path: Path, spec: ManipulatorSpec, signals: tuple[str, ...]) -> Experiment:
    from maniplab.sim.run import Run

    try:
        run = Run.load(path)
    except ManiplabError as e:
        raise DataError(f"{path}: {e}") from None
    if run.spec.joint_names != spec.joint_names:
        raise DataError(f"{path}: its arm has joints {', '.join(run.spec.joint_names)}, "
                        f"{spec.name} has {', '.join(spec.joint_names)}")
    _check_time(path, run.t)
    ctrl = run["ctrl"]
    inputs = {j: ctrl[:, k] for k, j in enumerate(spec.joint_names) if np.isfinite(ctrl[:, k]).all()}
    measured = {}
    for signal in signals:
        if signal in run.signals:
            values = run[signal]
            for k, joint in enumerate(spec.joint_names):
                if np.isfinite(values[:, k]).all():
                    measured[(signal, joint)] = values[:, k]
    return _experiment(path, spec, run.t - run.t[0], inputs, measured)


def _experiment(path: Path, spec: ManipulatorSpec, t: np.ndarray, inputs: dict[str, np.ndarray],
                measured: dict[tuple[str, str], np.ndarray]) -> Experiment:
    if not any(signal in ("q", "stroke") for signal, _ in measured):
        raise DataError(f"{path}: no measured position: give a column q.<joint> or "
                        f"stroke.<joint> for at least one joint of {spec.name}")
    zero = np.zeros_like(t)
    full = {joint: inputs.get(joint, zero) for joint in spec.joint_names}
    return Experiment(path.name, t, full, measured)


def save_csv(run: object, path: str | os.PathLike[str],
             signals: Iterable[str] = ("q", "dP")) -> Path:
    """Write a run as measurement CSV (the format above): t, every joint's ctrl, and the chosen
    measured signals of the joints that have them. For examples and tests."""
    from maniplab.atomic import atomic_path

    t = run.t  # type: ignore[attr-defined]
    names = run.spec.joint_names  # type: ignore[attr-defined]
    header, columns = ["t"], [t]
    for signal in (INPUT, *signals):
        values = run[signal]  # type: ignore[index]
        for k, joint in enumerate(names):
            if np.isfinite(values[:, k]).all():
                header.append(f"{signal}.{joint}")
                columns.append(values[:, k])
    table = np.column_stack(columns)
    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows([[repr(float(x)) for x in row] for row in table])
    return Path(path)
