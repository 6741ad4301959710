"""Parameters of the valve-controlled hydraulic cylinder, the ``actuator:`` section of a joint."""

from __future__ import annotations

from typing import ClassVar, Literal

from maniplab.schema import NonNegative, Positive, validated


@validated
class HydraulicActuator:
    """A valve-controlled hydraulic cylinder (eq. 4 of the paper), one per joint.

    Attributes:
        type: "hydraulic".
        area: piston area A, m² (prismatic joint), or displacement per radian, m³/rad (rotational).
        volume: effective oil volume V, m³.
        bulk_modulus: oil bulk modulus E, Pa.
        leakage: leakage coefficient Le, m³/(s·Pa).
        valve_gain: flow gain C, m³/(s·A): flow at current i_v with no load is i_v C.
        valve_tau: valve time constant τ, s.
        supply_pressure: Ps, Pa.
        current_limit: largest |i_v|, A.
    """

    EXAMPLE: ClassVar[str] = "type: hydraulic, area: 0.001, volume: 0.002, ..."

    type: Literal["hydraulic"]
    area: Positive
    volume: Positive
    valve_gain: Positive
    supply_pressure: Positive
    bulk_modulus: Positive = 1.4e9
    leakage: NonNegative = 0.0
    valve_tau: Positive = 0.01
    current_limit: Positive = 1.0
