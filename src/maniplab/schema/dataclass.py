"""Validated frozen dataclasses: pydantic dataclasses whose constructor raises SpecError."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar, overload

from pydantic import ConfigDict, ValidationError
from pydantic.dataclasses import dataclass as pydantic_dataclass
from typing_extensions import dataclass_transform

from maniplab.schema.translate import translate_errors

CONFIG = ConfigDict(extra="forbid", allow_inf_nan=False)
"""Unknown keys, NaN and infinities are errors."""

T = TypeVar("T")


@overload
def validated(cls: type[T], /) -> type[T]: ...


@overload
def validated(*, kw_only: bool = False) -> Callable[[type[T]], type[T]]: ...


@dataclass_transform(frozen_default=True)
def validated(cls: type[T] | None = None, /, *, kw_only: bool = False) -> Any:
    """Make ``cls`` a frozen dataclass validated by pydantic with the schema's rules (:data:`CONFIG`).

    Constructing it with a bad value raises :class:`~maniplab.errors.SpecError` naming the field,
    as a spec file does. Use it for every parameter section (``@validated class Params: ...``).
    """

    def wrap(plain: type[T]) -> type[T]:
        c: Any = pydantic_dataclass(frozen=True, config=CONFIG, kw_only=kw_only)(plain)
        init = c.__dict__["__init__"]

        @functools.wraps(init)
        def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
            try:
                init(self, *args, **kwargs)
            except ValidationError as exc:
                raise translate_errors(exc.errors(), root=c) from None

        setattr(c, "__init__", __init__)  # noqa: B010 - mypy forbids assigning to __init__
        return c

    return wrap if cls is None else wrap(cls)
