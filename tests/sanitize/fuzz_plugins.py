"""Fuzzing maniplab's MuJoCo engine plugins (hydraulic.c, cylinder.c, lugre.c, common.c) under
ASan and UBSan through the MJCF maniplab exports.

The exported MJCF of arms that use each plugin (crane3 and the erector: ``maniplab.hydraulic``,
erector_pinned: ``maniplab.cylinder`` too, a LuGre block: ``maniplab.lugre``) is given hostile
plugin configs: values replaced by hostile text (empty, NaN, inf, 1e309, negative, zero,
subnormal, hexadecimal, trailing garbage, 5000 digits, printf directives, non-ASCII), keys removed,
optional keys added (a relief valve, a shared pump, an unknown key), and the plugin actuators'
``actdim`` and ``ctrlrange`` changed. MuJoCo must either refuse the model (ValueError) or
simulate it: a few steps with hostile controls and activations. A memory error or undefined
behaviour in the plugins aborts the process with the sanitizer's report.

Run as a script (``python tests/sanitize/fuzz_plugins.py``) or with pytest in a sanitized
process (``python tests/sanitize/run.py``).
"""

from __future__ import annotations

import math
import sys
import xml.etree.ElementTree as ET
from functools import cache
from typing import Any

import numpy as np
import pytest
from hypothesis import event, given
from hypothesis import strategies as st
from sanitized import fuzz_settings, reexec_sanitized, spec_of

EXAMPLES = 80

PLUGIN_ARMS = ("crane3", "erector", "erector_pinned", "lugre-block")

TEXT = ["", " ", "nan", "NaN", "inf", "-inf", "1e309", "-1e309", "-1", "0", "-0", "1e-308",
        "5e-324", "1e308", "-1e308", "abc", "1e", "0x1p3", "1 2", "1,5", "+1", ".", "\t3\n",
        "1" * 5000, "%s%s%n%x", "é", "1e-30", "1e30", "orifice", "paper", "2.5e-3x"]
"""Hostile config values (text)."""

OPTIONAL = ["relief_pressure", "relief_gain", "pump_flow", "valve_law", "no_such_key"]
"""Keys the fuzz may add to a plugin instance's config."""

SCALES = [1e-300, 1e-12, 1e-6, 1e-3, 0.5, 2.0, 1e3, 1e6, 1e12, 1e300, -1.0]
"""Factors a config's number is scaled by: extreme, but mostly still valid, settings."""

HOSTILE = [math.nan, math.inf, -math.inf, 0.0, 1e308, -1e308, 1e-308, 1e10, -1e10, 1.0, -1.0,
           0.3]


@cache
def mjcf(arm: str) -> str:
    """The exported MJCF of an arm (maniplab's plugins loaded: ``import maniplab``)."""
    import maniplab as ml

    return ml.to_mjcf(spec_of(arm))


def value_text() -> st.SearchStrategy[str]:
    return st.one_of(st.sampled_from(TEXT),
                     st.floats(allow_nan=True, allow_infinity=True).map(repr),
                     st.floats(-1e3, 1e3).map(repr))


@st.composite
def mutations(draw: st.DrawFn) -> tuple[str, list[tuple[Any, ...]]]:
    arm = draw(st.sampled_from(PLUGIN_ARMS))
    root = ET.fromstring(mjcf(arm))
    configs = root.findall(".//extension/plugin/instance/config")
    instances = root.findall(".//extension/plugin/instance")
    actuators = root.findall(".//actuator/plugin")
    ops: list[tuple[Any, ...]] = []
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["scale"] * 6 + ["value", "value", "remove", "add",
                                                      "actdim", "ctrlrange", "share"]))
        if kind == "scale":
            ops.append((kind, draw(st.integers(0, len(configs) - 1)),
                        draw(st.sampled_from(SCALES))))
        elif kind in ("value", "remove"):
            ops.append((kind, draw(st.integers(0, len(configs) - 1)), draw(value_text())))
        elif kind == "add":
            ops.append((kind, draw(st.integers(0, len(instances) - 1)),
                        draw(st.sampled_from(OPTIONAL)), draw(value_text())))
        elif kind in ("actdim", "ctrlrange", "share") and actuators:
            ops.append((kind, draw(st.integers(0, len(actuators) - 1)),
                        draw(st.sampled_from(["0", "1", "2", "3", "4", "-1", "-1 1", "1 -1",
                                              "0 0", "nan nan", "-1e308 1e308"]))))
    return arm, ops


def mutate(arm: str, ops: list[tuple[Any, ...]]) -> str:
    root = ET.fromstring(mjcf(arm))
    configs = root.findall(".//extension/plugin/instance/config")
    instances = root.findall(".//extension/plugin/instance")
    actuators = root.findall(".//actuator/plugin")
    parents = {child: parent for parent in root.iter() for child in parent}
    for op in ops:
        kind = op[0]
        if kind == "value":
            configs[op[1]].set("value", op[2])
        elif kind == "scale":
            try:
                configs[op[1]].set("value", repr(float(configs[op[1]].get("value", "")) * op[2]))
            except ValueError:  # a word (valve_law)
                pass
        elif kind == "remove":
            element = configs[op[1]]
            if element in parents and element in list(parents[element]):
                parents[element].remove(element)
        elif kind == "add":
            ET.SubElement(instances[op[1]], "config", key=op[2], value=op[3])
        elif kind == "actdim":
            actuators[op[1]].set("actdim", op[2])
        elif kind == "ctrlrange":
            actuators[op[1]].set("ctrlrange", op[2])
        elif kind == "share":  # two actuators on one plugin instance
            actuators[op[1]].set("instance", actuators[0].get("instance", ""))
    return ET.tostring(root, encoding="unicode")


@fuzz_settings(EXAMPLES)
@given(case=mutations(), ctrl=st.lists(st.sampled_from(HOSTILE), min_size=1, max_size=8),
       act=st.lists(st.sampled_from(HOSTILE), min_size=1, max_size=8),
       integrator=st.sampled_from([0, 1, 2, 3]))
def test_plugin_configs(case: tuple[str, list[tuple[Any, ...]]], ctrl: list[float],
                        act: list[float], integrator: int) -> None:
    """A mutated exported MJCF: refused by MuJoCo, or simulated with hostile ctrl and act."""
    import mujoco

    import maniplab  # noqa: F401  (loads maniplab's plugins)

    text = mutate(*case)
    try:
        model = mujoco.MjModel.from_xml_string(text)
        data = mujoco.MjData(model)
    except ValueError as exc:
        event(f"refused: {str(exc).splitlines()[0][:40]}")
        return
    event("simulated")
    model.opt.integrator = integrator
    for k in range(12):
        if k == 4:
            data.ctrl[:] = np.resize(ctrl, model.nu)
        if k == 8 and model.na:
            data.act[:] = np.resize(act, model.na)
        mujoco.mj_step(model, data)
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    copy = mujoco.MjData(model)  # plugin data copied and freed with it
    del copy


def test_unmutated_arms_simulate() -> None:
    """The exported arms themselves compile and step (the fuzz's starting points are valid)."""
    import mujoco

    for arm in PLUGIN_ARMS:
        model = mujoco.MjModel.from_xml_string(mjcf(arm))
        data = mujoco.MjData(model)
        for _ in range(20):
            mujoco.mj_step(model, data)
        assert np.isfinite(data.qpos).all(), arm


if __name__ == "__main__":
    reexec_sanitized()
    sys.exit(pytest.main([__file__, "-q", "-p", "no:cacheprovider",
                          "-W", "ignore::pytest.PytestAssertRewriteWarning", *sys.argv[1:]]))
