"""The actuator parameters the controller needs, as per-joint arrays read from the spec."""

from __future__ import annotations

import dataclasses

import numpy as np

from maniplab.spec import HydraulicActuator, ManipulatorSpec


@dataclasses.dataclass(frozen=True, eq=False)
class ActuatorArrays:
    """Per-joint actuator parameters, shape (n,) each (eq. 4 symbols; see HydraulicActuator).

    Entries of torque joints are NaN in the hydraulic arrays (``torque_limit`` is inf where a
    torque joint has no limit and NaN at hydraulic joints).

    Attributes:
        hydraulic: True at hydraulic joints.
        area: A, m² or m³/rad.  volume: V, m³.  bulk_modulus: E, Pa.  leakage: Le, m³/(s·Pa).
        valve_gain: C, m³/(s·A).  valve_tau: τ, s.  supply_pressure: Ps, Pa.
        current_limit: A.  torque_limit: N or N·m.
    """

    hydraulic: np.ndarray
    area: np.ndarray
    volume: np.ndarray
    bulk_modulus: np.ndarray
    leakage: np.ndarray
    valve_gain: np.ndarray
    valve_tau: np.ndarray
    supply_pressure: np.ndarray
    current_limit: np.ndarray
    torque_limit: np.ndarray

    @classmethod
    def from_spec(cls, spec: ManipulatorSpec) -> ActuatorArrays:
        """Collect the arrays from the spec's joints."""
        fields = ("area", "volume", "bulk_modulus", "leakage", "valve_gain", "valve_tau",
                  "supply_pressure", "current_limit")
        values: dict[str, list[float]] = {f: [] for f in fields}
        hydraulic, torque_limit = [], []
        for joint in spec.joints:
            act = joint.actuator
            is_h = isinstance(act, HydraulicActuator)
            hydraulic.append(is_h)
            for f in fields:
                values[f].append(float(getattr(act, f)) if is_h else np.nan)
            limit = getattr(act, "limit", None)
            torque_limit.append(np.nan if is_h else (np.inf if limit is None else float(limit)))
        arrays = {f: np.array(v) for f, v in values.items()}
        return cls(hydraulic=np.array(hydraulic, dtype=bool), torque_limit=np.array(torque_limit),
                   **arrays)

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.hydraulic.shape[0]

    @property
    def capacitance(self) -> np.ndarray:
        """Hydraulic capacitance V/E, m³/Pa, shape (n,) (NaN at torque joints)."""
        return self.volume / self.bulk_modulus

    @property
    def command_limit(self) -> np.ndarray:
        """Largest |command|: current_limit at hydraulic joints, torque_limit elsewhere, (n,)."""
        return np.where(self.hydraulic, self.current_limit, self.torque_limit)
