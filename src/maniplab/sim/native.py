"""ctypes bindings of the plant in C (``maniplab_native/plant.h``): its structures and calls.

The C functions are called through ``ctypes.CDLL``, which releases the GIL for the length of each
call: a whole run (``ml_plant_run``) steps with no Python, so plants in several threads run in
parallel. Python is entered only where the run asks for it, through the C function pointers
made here (a Python controller, Python actuators' MuJoCo callbacks, a Python state check), whose
ctypes trampolines take the GIL back.
"""

from __future__ import annotations

import ctypes
from ctypes import POINTER, c_double, c_int, c_int64, c_void_p
from typing import Any

from maniplab.clib import Functions

# plant.h: statuses
(OK, PAUSED, UNSTABLE_MOTION, STATE_BOUND, BAD_COMMAND, CONTROLLER_ERROR, CALLBACK_ERROR,
 BAD_RUN) = range(8)

CONTROLLER = ctypes.CFUNCTYPE(c_int, c_void_p, c_double, c_void_p, c_void_p, POINTER(c_double))
"""``ml_controller_fn``: (context, t, model, data, u) -> status."""

ACTUATOR = ctypes.CFUNCTYPE(c_int, c_int, c_int, POINTER(c_double))
"""``ml_actuator_fn``: (kind 0 act_dyn / 1 act_bias, actuator id, out) -> status."""

CHECK = ctypes.CFUNCTYPE(c_int)
"""``ml_check_fn``: () -> the joint with a bad state, -1 for none, -2 when the check raised."""

_D = POINTER(c_double)
_I = POINTER(c_int)


class Config(ctypes.Structure):
    """``ml_plant_config``."""

    _fields_ = [
        ("n", c_int), ("substeps", c_int), ("hold_inertia", c_double),
        ("lower", _D), ("upper", _D), ("command_limit", _D), ("slip", _I),
        ("coulomb", _D), ("stiction", _D), ("stribeck", _D), ("stick_velocity", _D),
        ("nbounds", c_int), ("bound_adr", _I), ("bound_value", _D), ("bound_joint", _I),
        ("rod", _I), ("rod_coulomb", _D), ("rod_stiction", _D), ("rod_stribeck", _D),
        ("rod_viscous", _D), ("rod_stick_velocity", _D),
    ]


class RunStruct(ctypes.Structure):
    """``ml_run``."""

    _fields_ = [
        ("steps", c_int64), ("t0", c_double), ("dt", c_double), ("k", c_int64),
        ("max_steps", c_int), ("inputs", _D), ("inputs_k0", c_int64), ("held", _D),
        ("controller", c_void_p), ("controller_context", c_void_p),
        ("period", c_double), ("next_call", c_double), ("every", c_int64), ("rows", c_int),
        ("t", _D), ("q", _D), ("qd", _D), ("act", _D), ("ctrl", _D),
        ("mode", POINTER(ctypes.c_byte)), ("fric", _D), ("limit", _D), ("ee_body", c_int),
        ("ee_pos", _D), ("plugin_state", _D), ("columns", c_int),
    ]


class Error(ctypes.Structure):
    """``ml_error``."""

    _fields_ = [("status", c_int), ("joint", c_int), ("index", c_int), ("time", c_double)]


_SIGNATURES: dict[str, tuple[Any, list[Any]]] = {
    "ml_plant_new": (c_void_p, [c_void_p, c_void_p, POINTER(Config)]),
    "ml_plant_free": (None, [c_void_p]),
    "ml_plant_set_python": (None, [c_void_p, ACTUATOR, CHECK]),
    "ml_plant_resync": (None, [c_void_p]),
    "ml_plant_prepare": (c_int, [c_void_p, _D]),
    "ml_plant_advance": (c_int, [c_void_p]),
    "ml_plant_run": (c_int, [c_void_p, POINTER(RunStruct)]),
    "ml_plant_record": (None, [c_void_p, _D, _D, _D, _D, POINTER(ctypes.c_byte), _D, _D]),
    "ml_plant_modes": (None, [c_void_p, POINTER(ctypes.c_byte)]),
    "ml_plant_error": (Error, [c_void_p]),
}

_FUNCTIONS = Functions(_SIGNATURES)


def library() -> ctypes.CDLL:
    """maniplab's native library with the plant's functions declared (built on first use).

    Raises:
        ModelError: the library could not be built (no C compiler...), one line.
    """
    return _FUNCTIONS()


def doubles(values: Any) -> Any:
    """A ctypes array of doubles holding ``values``."""
    values = [float(v) for v in values]
    return (c_double * max(1, len(values)))(*values)


def ints(values: Any) -> Any:
    """A ctypes array of ints holding ``values``."""
    values = [int(v) for v in values]
    return (c_int * max(1, len(values)))(*values)


def pointer(array: Any, ctype: Any = c_double) -> Any:
    """A ctypes pointer to a numpy array's data (the array must stay alive and contiguous)."""
    return array.ctypes.data_as(POINTER(ctype))
