"""Hoses between a valve and a pinned cylinder: their oil volume and its effective bulk modulus.

A hose holds oil that the piston does not sweep, and it is softer than that oil alone: its wall
swells with the pressure, and oil carries some entrained air. Following Merritt (Hydraulic Control
Systems, Wiley 1967, §2.3), the effective bulk modulus β_e of the hose's contents is the
series of the three compliances,

    1/β_e = 1/β_oil + 1/β_wall + ε(p)/(κ p),

β_oil the oil's, β_wall the wall's (V_h Δp/ΔV_h, from a datasheet's volumetric expansion ΔV_h at
Δp), and the air's volume fraction ε(p) over its adiabatic bulk modulus κ p (κ = 1.4, p absolute).
This is Merritt's form, the oil's term 1/β_oil over the whole volume; the mixture's exact
(1 - ε)/β_oil differs from it by ε/β_oil, a share κ p/β_oil of the air's term (1 % at 8 MPa and
β_oil = 1 GPa).
The air is given as its fraction ε0 of free air at atmospheric pressure p_atm; compressed
adiabatically to p (the oil's volume taken as constant), its fraction is

    ε(p) = ε0 r / (1 - ε0 + ε0 r),    r = (p_atm/p)^(1/κ).

The pinned cylinder's chamber equation is dp/dt = β_oil/V(s) · (flows), one constant bulk
modulus over the chamber volume V(s) = V_0 + swept. A hose on the chamber adds its compliance
V_h/β_e to the chamber's V(s)/β_oil, and V(s)/β_oil + V_h/β_e = (V(s) + V_h β_oil/β_e)/β_oil
exactly: a hose is an *equivalent dead volume* V_h β_oil/β_e added to its chamber's, and nothing
else changes. Because that constant must not depend on the chamber's pressure, the air's term is
taken at one reference pressure, the supply's (absolute: the spec's supply pressure, a gauge
pressure as hydraulic circuits state them, plus :data:`P_ATM`). The air's compliance grows as
p^-(1+1/κ) below it (about 50 times at a tenth of the supply), so with air the model is right at
the working pressure and too stiff near tank.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar

from pydantic import BeforeValidator, Field, Strict

from maniplab.schema import Positive, validated
from maniplab.schema.fields import number

P_ATM = 101325.0
"""Atmospheric pressure, Pa: where the entrained air's fraction is given, and what turns the
spec's (gauge) supply pressure into the absolute pressure the air's term needs."""

KAPPA = 1.4
"""The ratio of the air's specific heats: its compression in a fast pressure change is adiabatic,
p V^κ constant, and its bulk modulus κ p."""

MAX_AIR = 0.2
"""The entrained air's fraction must stay below this: beyond it the oil is a foam and Merritt's
series formula (and a constant bulk modulus) no longer describe it."""

AirFraction = Annotated[float, Strict(), Field(ge=0.0, lt=MAX_AIR), BeforeValidator(number)]
"""A free-air volume fraction in [0, :data:`MAX_AIR`)."""


def hose_volume(length: float, inner_diameter: float) -> float:
    """V_h = π d²/4 · L, m³, of a hose of inner diameter d (m) and length L (m)."""
    return math.pi / 4.0 * inner_diameter**2 * length


def air_fraction(air: float, pressure: float) -> float:
    """ε(p) = ε0 r / (1 - ε0 + ε0 r), r = (p_atm/p)^(1/κ): the volume fraction of air ``air``
    (ε0, free air at :data:`P_ATM`) compressed adiabatically to the absolute ``pressure`` p (Pa),
    the oil's volume constant."""
    r = (P_ATM / pressure) ** (1.0 / KAPPA)
    return air * r / (1.0 - air + air * r)


def effective_bulk_modulus(oil: float, pressure: float, wall: float | None = None,
                           air: float = 0.0) -> float:
    """β_e of oil in a hose, Pa (Merritt 1967, §2.3): 1/β_e = 1/β_oil + 1/β_wall + ε(p)/(κ p).

    Args:
        oil: β_oil, Pa.
        pressure: p, absolute, Pa: where the air's fraction and modulus are taken.
        wall: β_wall, Pa, or None for a rigid wall (no term).
        air: ε0, the free-air fraction at :data:`P_ATM` (:func:`air_fraction`).
    """
    compliance = 1.0 / oil
    if wall is not None:
        compliance += 1.0 / wall
    if air > 0.0:
        compliance += air_fraction(air, pressure) / (KAPPA * pressure)
    return 1.0 / compliance


@validated
class Hose:
    """A hose between the valve and one chamber of a cylinder.

    Attributes:
        length: m.
        inner_diameter: m.
        wall_bulk_modulus: β_wall, Pa: the wall's swelling as a bulk modulus, V_h Δp/ΔV_h from
            the volumetric expansion ΔV_h a datasheet gives at a pressure Δp; None (the default)
            for a rigid wall.
        air: the entrained free-air volume fraction at atmospheric pressure, ε0 (default 0), less
            than 0.2.
    """

    EXAMPLE: ClassVar[str] = "length: 3.0, inner_diameter: 0.0127, air: 0.005"

    length: Positive
    inner_diameter: Positive
    wall_bulk_modulus: Positive | None = None
    air: AirFraction = 0.0

    @property
    def volume(self) -> float:
        """V_h = π d²/4 · L, m³."""
        return hose_volume(self.length, self.inner_diameter)

    def bulk_modulus(self, oil: float, pressure: float) -> float:
        """β_e of its contents at the absolute ``pressure`` (Pa), with oil of bulk modulus
        ``oil`` (Pa): :func:`effective_bulk_modulus`."""
        return effective_bulk_modulus(oil, pressure, self.wall_bulk_modulus, self.air)

    def equivalent_volume(self, oil: float, pressure: float) -> float:
        """V_h β_oil/β_e, m³: the dead volume of oil alone that is as compliant as the hose."""
        return self.volume * oil / self.bulk_modulus(oil, pressure)


@validated
class Hoses:
    """The hoses of a cylinder, each optional.

    Attributes:
        a: to the cap-side chamber (:class:`Hose`), or None.
        b: to the rod-side chamber, or None.
    """

    EXAMPLE: ClassVar[str] = ("a: {length: 3.0, inner_diameter: 0.0127}, "
                              "b: {length: 3.0, inner_diameter: 0.0127}")

    a: Hose | None = None
    b: Hose | None = None

    def equivalent_volumes(self, oil: float, pressure: float) -> tuple[float, float]:
        """Each hose's :meth:`Hose.equivalent_volume` (0 without one), cap side and rod side, m³,
        at the absolute ``pressure`` (Pa) with oil of bulk modulus ``oil`` (Pa)."""
        a, b = (0.0 if h is None else h.equivalent_volume(oil, pressure) for h in (self.a, self.b))
        return a, b
