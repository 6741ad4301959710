"""Typed fields of parameter dataclasses: numbers, vectors, and their conversion to plain data.

Numbers may be written as integers or floats (``1e-11`` is a float); booleans, text, NaN and
infinities are rejected where a number is expected, and so are numbers beyond ±:data:`LARGEST`
and positive quantities below :data:`SMALLEST`: the model multiplies and divides them (a mass by
a length squared, a bulk modulus by an area squared over a volume), and such products would
overflow to infinity or NaN. ``-0.0`` is read as ``0.0``. Vectors are lists (or tuples, or numpy
arrays) of exactly as many numbers as the field's type says.
"""

from __future__ import annotations

import enum
import math
from typing import Annotated, Any

import numpy as np
from pydantic import AfterValidator, BeforeValidator, Field, Strict
from pydantic_core import PydanticCustomError

LARGEST = 1e18
"""The largest magnitude of any number in a spec, SI units: a product of a dozen such numbers is
still finite in double precision (up to ~1.8e308)."""

SMALLEST = 1e-18
"""The smallest value of a positive quantity (a volume, an area, a time constant, a mass), SI
units: the model divides by them."""


def number(value: Any) -> Any:
    """Accept numpy scalars and integers as floats; reject magnitudes beyond :data:`LARGEST`."""
    if isinstance(value, (bool, np.bool_)):
        return value  # rejected by the strict float schema: True is not a number
    if isinstance(value, (int, np.integer, np.floating)):
        try:
            value = float(value)
        except OverflowError:
            raise PydanticCustomError(
                "finite_number", "Input should be a finite number"
            ) from None
    if isinstance(value, float) and abs(value) > LARGEST and math.isfinite(value):
        raise _problem(f"{value:g} is beyond ±{_short(LARGEST)}, the largest number a spec may "
                       "hold (SI units): the model's products of it would overflow")
    if isinstance(value, float) and value == 0.0:
        return 0.0  # not -0.0: the same quantity, written and compared the same way
    return value


def not_vanishing(value: float) -> float:
    """Reject a positive value below :data:`SMALLEST` (0 stays allowed where the field allows it)."""
    if 0.0 < value < SMALLEST:
        raise _problem(f"{value:g} is below {_short(SMALLEST)}, the smallest positive value a "
                       "spec may hold (SI units): the model divides by it")
    return value


def _short(bound: float) -> str:
    """``1e+18`` -> ``1e18``."""
    return f"{bound:.0e}".replace("e+", "e")


def _problem(problem: str) -> PydanticCustomError:
    return PydanticCustomError("spec_problem", "{problem}", {"problem": problem, "field": ""})


def sequence(value: Any) -> Any:
    """Accept lists, tuples and numpy arrays as vectors; reject sets, mappings, text, generators."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return value
    raise PydanticCustomError("tuple_type", "Input should be a valid list")


Real = Annotated[float, Strict(), BeforeValidator(number)]
"""Any finite number."""
NonNegative = Annotated[float, Strict(), Field(ge=0.0), BeforeValidator(number)]
"""A finite number >= 0."""
Positive = Annotated[float, Strict(), Field(gt=0.0), BeforeValidator(number),
                     AfterValidator(not_vanishing)]
"""A finite number > 0 (at least :data:`SMALLEST`)."""
UnitInterval = Annotated[float, Strict(), Field(gt=0.0, le=1.0), BeforeValidator(number),
                         AfterValidator(not_vanishing)]
"""A number in (0, 1]."""
Vec3 = Annotated[tuple[Real, Real, Real], BeforeValidator(sequence)]
"""A list of 3 finite numbers."""


def plain(value: Any) -> Any:
    """Tuples, enums and numpy scalars as YAML/JSON-friendly lists, strings and floats."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (tuple, list)):
        return [plain(v) for v in value]
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, np.integer):
        return int(value)
    return value
