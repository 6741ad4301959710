"""Fuzzing an FMU's C functions (fmu/fmu.c with the plant and plugins) under ASan and UBSan.

The FMU of crane3 is built with ``MANIPLAB_NATIVE_SANITIZE=1`` (its C compiled with the
sanitizers), unzipped and loaded with ctypes in this process. Hypothesis then drives sequences of
FMI 2.0 calls in any order (out-of-order calls included: a step before initialisation, values
set after it, terminate or reset in the middle) with hostile values: value references out of
range, counts of zero, NaN/inf/huge parameters, start values, inputs, start times and
communication steps; fmi2Instantiate with a wrong GUID, type, no resource location, a location
that is not a file URI or names no model.xml, and a model.xml with unknown, unterminated or
overlong ``${tokens}``, empty or binary. Every call must return a status; a memory error or
undefined behaviour aborts the process with the sanitizer's report.

Run as a script (``python tests/sanitize/fuzz_fmu.py``) or with pytest in a sanitized process
(``python tests/sanitize/run.py``).
"""

from __future__ import annotations

import ctypes
import math
import os
import sys
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from ctypes import POINTER, c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p
from functools import cache
from pathlib import Path
from typing import Any

import pytest
from hypothesis import event, given
from hypothesis import strategies as st
from sanitized import fuzz_settings, reexec_sanitized

EXAMPLES = 40

HOSTILE = [math.nan, math.inf, -math.inf, 0.0, -0.0, 5e-324, 1e-308, 1e308, -1e308, 1e10,
           -1e10, 1.0, -1.0, 0.5, 1e-3, 2e-3]

LOGGER = ctypes.CFUNCTYPE(None, c_void_p, c_char_p, c_int, c_char_p, c_char_p)
"""fmi2CallbackLogger (its variadic tail unused: the FMU passes a finished message)."""


class Callbacks(ctypes.Structure):
    _fields_ = [("logger", LOGGER), ("allocateMemory", c_void_p), ("freeMemory", c_void_p),
                ("stepFinished", c_void_p), ("componentEnvironment", c_void_p)]


MESSAGES: list[bytes] = []


@LOGGER
def _log(env: Any, name: bytes, status: int, category: bytes, message: bytes) -> None:
    MESSAGES.append(message)


@cache
def fmu() -> tuple[Any, Path, str, int]:
    """The sanitized FMU of crane3: its library, resources folder, GUID and number of variables."""
    from maniplab.fmu.build import build_fmu

    folder = Path(tempfile.mkdtemp(prefix="maniplab-fuzz-fmu-"))
    path = build_fmu("crane3", folder / "crane3.fmu", progress=False)
    with zipfile.ZipFile(path) as z:
        z.extractall(folder / "x")
    root = ET.parse(folder / "x" / "modelDescription.xml").getroot()
    guid = root.get("guid", "")
    nvar = len(root.findall(".//ModelVariables/ScalarVariable"))
    lib = ctypes.CDLL(str(next((folder / "x" / "binaries" / "linux64").glob("crane3.so"))))
    for name in ("fmi2Instantiate",):
        getattr(lib, name).restype = c_void_p
        getattr(lib, name).argtypes = [c_char_p, c_int, c_char_p, c_char_p, POINTER(Callbacks),
                                       c_int, c_int]
    lib.fmi2FreeInstance.argtypes = [c_void_p]
    lib.fmi2FreeInstance.restype = None
    for name, args in {
        "fmi2SetupExperiment": [c_void_p, c_int, c_double, c_double, c_int, c_double],
        "fmi2EnterInitializationMode": [c_void_p], "fmi2ExitInitializationMode": [c_void_p],
        "fmi2Terminate": [c_void_p], "fmi2Reset": [c_void_p],
        "fmi2SetDebugLogging": [c_void_p, c_int, c_size_t, c_void_p],
        "fmi2GetReal": [c_void_p, POINTER(c_uint), c_size_t, POINTER(c_double)],
        "fmi2SetReal": [c_void_p, POINTER(c_uint), c_size_t, POINTER(c_double)],
        "fmi2GetInteger": [c_void_p, POINTER(c_uint), c_size_t, POINTER(c_int)],
        "fmi2SetInteger": [c_void_p, POINTER(c_uint), c_size_t, POINTER(c_int)],
        "fmi2GetBoolean": [c_void_p, POINTER(c_uint), c_size_t, POINTER(c_int)],
        "fmi2DoStep": [c_void_p, c_double, c_double, c_int],
        "fmi2CancelStep": [c_void_p],
        "fmi2GetStatus": [c_void_p, c_int, POINTER(c_int)],
        "fmi2GetRealStatus": [c_void_p, c_int, POINTER(c_double)],
        "fmi2GetBooleanStatus": [c_void_p, c_int, POINTER(c_int)],
        "fmi2GetFMUstate": [c_void_p, POINTER(c_void_p)],
    }.items():
        fn = getattr(lib, name)
        fn.argtypes, fn.restype = args, c_int
    return lib, folder / "x" / "resources", guid, nvar


def call(lib: Any, c: int, op: tuple[Any, ...]) -> int:
    """One FMI call on instance c."""
    kind = op[0]
    if kind in ("GetReal", "SetReal", "GetInteger", "SetInteger", "GetBoolean"):
        refs = op[1]
        vr = (c_uint * max(1, len(refs)))(*refs)
        if kind in ("GetReal", "SetReal"):
            values = (c_double * max(1, len(refs)))(*op[2][:len(refs)])
        else:
            values = (c_int * max(1, len(refs)))()
        return int(getattr(lib, f"fmi2{kind}")(c, vr, len(refs), values))
    if kind == "DoStep":
        return int(lib.fmi2DoStep(c, op[1], op[2], 1))
    if kind == "Setup":
        return int(lib.fmi2SetupExperiment(c, 0, 0.0, op[1], 0, 0.0))
    if kind == "Logging":
        return int(lib.fmi2SetDebugLogging(c, op[1], 0, None))
    if kind == "Status":
        out_i, out_d = c_int(), c_double()
        return (int(lib.fmi2GetStatus(c, op[1], ctypes.byref(out_i)))
                + int(lib.fmi2GetRealStatus(c, op[1], ctypes.byref(out_d)))
                + int(lib.fmi2GetBooleanStatus(c, op[1], ctypes.byref(out_i))))
    if kind == "FMUstate":
        state = c_void_p()
        return int(lib.fmi2GetFMUstate(c, ctypes.byref(state)))
    return int(getattr(lib, f"fmi2{kind}")(c))


@st.composite
def programs(draw: st.DrawFn) -> list[tuple[Any, ...]]:
    nvar = fmu()[3]
    ref = st.one_of(st.integers(0, nvar - 1), st.integers(0, nvar - 1),
                    st.sampled_from([nvar, nvar + 1, 2**31, 2**32 - 1]))
    refs = st.lists(ref, max_size=4)
    number = st.one_of(st.sampled_from(HOSTILE), st.floats(-1.0, 1.0),
                       st.floats(allow_nan=True, allow_infinity=True))
    values = st.lists(number, min_size=4, max_size=4)
    # steps: whole, or refused (a step of 1e10 s would be 1e13 valid steps: not fuzzed)
    step = st.one_of(st.integers(1, 20).map(lambda k: k * 1e-3),
                     st.sampled_from([x for x in HOSTILE if not 0.05 < abs(x) < 1e19]),
                     st.sampled_from([1e-3 * (1 + 1e-9), 1.5e-3, 1e300, 1e20]))
    op = st.one_of(
        st.tuples(st.just("GetReal"), refs, values), st.tuples(st.just("SetReal"), refs, values),
        st.tuples(st.just("SetReal"), refs, values),
        st.tuples(st.just("GetInteger"), refs), st.tuples(st.just("SetInteger"), refs),
        st.tuples(st.just("GetBoolean"), refs),
        st.tuples(st.just("DoStep"), st.sampled_from([0.0, math.nan, -1.0]), step),
        st.tuples(st.just("DoStep"), st.just(0.0), step),
        st.tuples(st.just("DoStep"), st.just(0.0), step),
        st.tuples(st.just("Setup"), st.sampled_from(HOSTILE)),
        st.tuples(st.just("Logging"), st.integers(0, 1)),
        st.tuples(st.just("Status"), st.integers(-1, 5)),
        st.sampled_from([("EnterInitializationMode",), ("ExitInitializationMode",),
                         ("ExitInitializationMode",), ("Terminate",), ("Reset",),
                         ("CancelStep",), ("FMUstate",)]),
    )
    start = [("EnterInitializationMode",), ("ExitInitializationMode",)]
    ops = draw(st.lists(op, min_size=1, max_size=14))
    return ops if draw(st.integers(0, 3)) == 0 else (start + ops)


@fuzz_settings(EXAMPLES)
@given(program=programs())
def test_fmi_calls(program: list[tuple[Any, ...]]) -> None:
    """A sequence of FMI calls in any order with hostile values on one instance."""
    lib, resources, guid, _ = fmu()
    callbacks = Callbacks(logger=_log)
    c = lib.fmi2Instantiate(b"fuzz", 1, guid.encode(), resources.as_uri().encode(),
                            ctypes.byref(callbacks), 0, 1)
    assert c
    try:
        for op in program:
            status = call(lib, c, op)
            event(f"{op[0]}: {'ok' if status == 0 else 'refused'}")
    finally:
        lib.fmi2FreeInstance(c)
        MESSAGES.clear()


MODEL_TEXTS = [b"", b"\x00\xff\xfe binary", b"<mujoco/>", b"${", b"${plugin", b"${nosuch}",
               b"${" + b"x" * 5000 + b"}", b"${${${}}}", b"<mujoco>${plugin}" * 200,
               b"%s%n${plugin}"]


@fuzz_settings(EXAMPLES // 2)
@given(guid=st.sampled_from(["right"] * 4 + ["", "{0}", None]),
       kind=st.sampled_from([1] * 4 + [0, 2, -1]),
       location=st.sampled_from(["right"] * 4 + ["text"] * 4 + ["", None, "http://x/", "file:", "file:///nonexistent",
                                 "file://localhost/tmp", "file:///%", "file:///%zz/%41",
                                 "text", "folder-named-model.xml"]),
       text=st.one_of(st.none(), st.sampled_from(MODEL_TEXTS)),
       exit_init=st.booleans(), callbacks=st.booleans())
def test_instantiate(guid: str | None, kind: int, location: str | None, text: bytes | None,
                     exit_init: bool, callbacks: bool) -> None:
    """fmi2Instantiate with hostile arguments and resources, then initialisation and a step."""
    lib, resources, right_guid, _ = fmu()
    folder = Path(tempfile.mkdtemp(prefix="maniplab-fuzz-res-"))
    uri: str | None = location
    if location == "right":
        uri = resources.as_uri()
    elif location == "text":
        (folder / "model.xml").write_bytes(text or b"")
        uri = folder.as_uri()
    elif location == "folder-named-model.xml":
        (folder / "model.xml").mkdir()
        uri = folder.as_uri()
    if text is not None and location == "right":  # the FMU's model with a hostile tail
        original = (resources / "model.xml").read_bytes()
        (folder / "model.xml").write_bytes(original + text)
        uri = folder.as_uri()
    g = right_guid if guid == "right" else guid
    cbs = Callbacks(logger=_log)
    c = lib.fmi2Instantiate(b"fuzz", kind, g.encode() if g is not None else None,
                            uri.encode() if uri is not None else None,
                            ctypes.byref(cbs) if callbacks else None, 0, 1)
    event("instantiated" if c else "refused")
    if c:
        try:
            lib.fmi2EnterInitializationMode(c)
            if exit_init:
                status = lib.fmi2ExitInitializationMode(c)
                event(f"exit: {status}")
                lib.fmi2DoStep(c, 0.0, 1e-3, 1)
        finally:
            lib.fmi2FreeInstance(c)
    MESSAGES.clear()
    for file in folder.rglob("*"):
        if file.is_file():
            file.unlink()
    for sub in sorted(folder.rglob("*"), reverse=True):
        sub.rmdir()
    os.rmdir(folder)


if __name__ == "__main__":
    reexec_sanitized()
    sys.exit(pytest.main([__file__, "-q", "-p", "no:cacheprovider",
                          "-W", "ignore::pytest.PytestAssertRewriteWarning", *sys.argv[1:]]))
