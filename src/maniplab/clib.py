"""maniplab's compiled library (:mod:`maniplab_native`) for ctypes calls of its exported functions.

The modules that call C (the valve law, the compiled cascade) declare the functions they use with
:class:`Functions`; the library is built on first use, and a build failure (no C compiler) is a
one-line :class:`~maniplab.errors.ModelError`, as everywhere else the library is needed.

Pointer arguments are declared ``c_void_p`` and passed as addresses (``array.ctypes.data``), the
cheapest conversion ctypes has; the arrays must be contiguous float64 (or ``intc``) and stay alive
for the call.
"""

from __future__ import annotations

import ctypes
import threading
from typing import Any

import maniplab_native
from maniplab.errors import ModelError

_LOCK = threading.Lock()


class Functions:
    """Some exported C functions, declared (argtypes, restype) on first use.

    Args:
        signatures: C function name -> (restype, argtypes).

    Example:
        >>> C = Functions({"ml_relief_flow": (c_double, [c_double, c_double, c_double])})
        >>> C().ml_relief_flow(20e6, 19e6, 1e-9)
    """

    def __init__(self, signatures: dict[str, tuple[Any, list[Any]]]) -> None:
        self._signatures = signatures
        self._lib: ctypes.CDLL | None = None

    def __call__(self) -> ctypes.CDLL:
        """The library with these functions declared.

        Raises:
            ModelError: the library could not be built (no C compiler...), one line.
        """
        if self._lib is None:
            with _LOCK:
                self._lib = self._declare()
        return self._lib

    def _declare(self) -> ctypes.CDLL:
        try:
            lib = maniplab_native.library()
        except maniplab_native.NativeBuildError as exc:
            raise ModelError(str(exc)) from None
        for name, (restype, argtypes) in self._signatures.items():
            fn = getattr(lib, name)
            fn.restype, fn.argtypes = restype, argtypes
        return lib

    def address(self, name: str) -> int:
        """The address of the C function ``name`` (for a C caller's function pointer)."""
        value = ctypes.cast(getattr(self(), name), ctypes.c_void_p).value
        assert value is not None, f"{name} has no address"
        return value
