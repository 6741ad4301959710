"""Parameters of the valve-controlled hydraulic cylinder, the ``actuator:`` section of a joint."""

from __future__ import annotations

from typing import ClassVar, Literal

from maniplab.actuators.hydraulic.valve import relief_gain
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
        valve_law: "orifice" (the default: the flow follows the pressure drop across the
            metering edges, so a lowered load is braked) or "paper" (eq. 4 literally: the flow
            falls with |ΔP| whichever way the load acts); see :mod:`.valve`.
        relief_pressure: setting of a relief valve across the cylinder, Pa, or None for none.
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
    valve_law: Literal["orifice", "paper"] = "orifice"
    relief_pressure: Positive | None = None

    @property
    def orifice(self) -> bool:
        """True for the orifice law."""
        return self.valve_law == "orifice"

    @property
    def relief_gain(self) -> float:
        """K_r of the relief valve, m³/(s·Pa) (0 without one)."""
        if self.relief_pressure is None:
            return 0.0
        return relief_gain(self.valve_gain, self.current_limit, self.relief_pressure)
