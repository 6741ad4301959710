"""Typed fields of parameter dataclasses: numbers, vectors, and their conversion to plain data.

Numbers may be written as integers or floats (``1e-11`` is a float); booleans, text, NaN and
infinities are rejected where a number is expected. Vectors are lists (or tuples, or numpy arrays)
of exactly as many numbers as the field's type says.
"""

from __future__ import annotations

import enum
from typing import Annotated, Any

import numpy as np
from pydantic import BeforeValidator, Field, Strict
from pydantic_core import PydanticCustomError


def number(value: Any) -> Any:
    """Accept numpy scalars as floats; reject integers too large for a float."""
    if isinstance(value, (bool, np.bool_)):
        return value  # rejected by the strict float schema: True is not a number
    if isinstance(value, (np.integer, np.floating)):
        return float(value)
    if isinstance(value, int):
        try:
            return float(value)
        except OverflowError:
            raise PydanticCustomError(
                "finite_number", "Input should be a finite number"
            ) from None
    return value


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
Positive = Annotated[float, Strict(), Field(gt=0.0), BeforeValidator(number)]
"""A finite number > 0."""
UnitInterval = Annotated[float, Strict(), Field(gt=0.0, le=1.0), BeforeValidator(number)]
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
