"""The FMU's units by their SI base-unit exponents, against a table derived here from the units'
definitions (issue 42: they were compared by name only, so a wrong exponent would ship)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from maniplab.fmu.description import model_description
from maniplab.fmu.template import model_template
from maniplab.fmu.variables import variables
from maniplab.sim.plant import Plant

# Derived by hand: N = kg m s⁻², Pa = N m⁻² = kg m⁻¹ s⁻², leakage m³/(s Pa) = kg⁻¹ m⁴ s,
# viscous friction N s/m = kg s⁻¹ and N m s/rad = kg m² s⁻¹ rad⁻¹.
SI = {
    "m": {"m": 1}, "rad": {"rad": 1}, "m/s": {"m": 1, "s": -1}, "rad/s": {"rad": 1, "s": -1},
    "Pa": {"kg": 1, "m": -1, "s": -2}, "m3/s": {"m": 3, "s": -1}, "A": {"A": 1},
    "N": {"kg": 1, "m": 1, "s": -2}, "N.m": {"kg": 1, "m": 2, "s": -2}, "kg": {"kg": 1},
    "m3/(s.Pa)": {"kg": -1, "m": 4, "s": 1}, "N.s/m": {"kg": 1, "s": -1},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1},
}


@pytest.mark.parametrize("arm", ["erector", "erector_pinned", "planar2"])
def test_every_unit_has_its_si_exponents(arm: str) -> None:
    plant = Plant(arm)
    table = variables(plant, model_template(plant)[1])
    root = ET.fromstring(model_description(name=arm, identifier=arm, guid="{0}", description="",
                                           dt=plant.dt, variables=table).split("\n", 1)[1])
    units = {u.get("name"): u.find("BaseUnit") for u in root.iter("Unit")}
    assert units, "no UnitDefinitions"
    for name, base in units.items():
        assert name in SI, f"unit {name} has no entry in this test's table"
        exponents = {k: int(v) for k, v in base.attrib.items() if k != "factor"}
        assert exponents == SI[name], name
    used = {r.get("unit") for r in root.iter("Real") if r.get("unit")}
    assert used <= set(units)
