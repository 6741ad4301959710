"""Joint friction parameters, the ``friction:`` section of a joint in a spec."""

from __future__ import annotations

import enum
from typing import ClassVar

from maniplab.schema import NonNegative, Positive, validated


class FrictionModel(str, enum.Enum):
    """Joint friction model: none, the hybrid stick/slip automaton, or LuGre."""

    none = "none"
    hybrid = "hybrid"
    lugre = "lugre"


@validated
class Friction:
    """Joint friction parameters (units N, N·s/m, m/s on prismatic joints; N·m, rad/s on rotational).

    ``static`` is the stiction above Coulomb: the break-away force is ``coulomb + static``.
    The hybrid model uses coulomb, static, stribeck_velocity, viscous and stick_velocity; LuGre
    uses the same plus sigma0 (bristle stiffness) and sigma1 (bristle damping).
    """

    EXAMPLE: ClassVar[str] = "model: hybrid, coulomb: 100.0"

    model: FrictionModel = FrictionModel.none
    coulomb: NonNegative = 0.0
    static: NonNegative = 0.0
    stribeck_velocity: Positive = 0.01
    viscous: NonNegative = 0.0
    stick_velocity: Positive = 1e-3
    sigma0: Positive = 1e5
    sigma1: NonNegative = 316.2

    @property
    def breakaway(self) -> float:
        """Fc + Fs, N or N·m: the largest force stiction holds (hybrid and LuGre)."""
        return self.coulomb + self.static

    @property
    def damping(self) -> float:
        """The viscous coefficient that acts on the joint (0 without a friction model)."""
        return self.viscous if self.model is not FrictionModel.none else 0.0
