"""The vocabulary of maniplab's parameter files: typed fields, validated frozen dataclasses, and
the translation of validation failures into one-line :class:`~maniplab.errors.SpecError`.

Everything that a spec file holds is declared with these: the arm (:mod:`maniplab.spec`), the
actuators' parameters (:mod:`maniplab.actuators`, and any plugin's ``Params``) and the friction
parameters (:mod:`maniplab.friction`). The module knows no part of an arm; it is the layer that
the others build on, so it imports nothing of maniplab but :mod:`maniplab.errors`.
"""

from maniplab.schema.dataclass import CONFIG, validated
from maniplab.schema.fields import (
    LARGEST,
    SMALLEST,
    NonNegative,
    Positive,
    Real,
    UnitInterval,
    Vec3,
    not_vanishing,
    plain,
    sequence,
)
from maniplab.schema.translate import describe, translate_errors, unknown_key_problem

__all__ = [
    "CONFIG",
    "LARGEST",
    "SMALLEST",
    "NonNegative",
    "Positive",
    "Real",
    "UnitInterval",
    "Vec3",
    "describe",
    "not_vanishing",
    "plain",
    "sequence",
    "translate_errors",
    "unknown_key_problem",
    "validated",
]
