"""Hoses on a pinned cylinder (issue 34): a hose's volume and effective bulk modulus against hand
numbers and an independent derivation, a hose simulating exactly as the equivalent dead volume
computed here, the blocked chamber's pressure rise and the oil spring against the total
compliance, and bad hoses refused with one line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from commandline import run_cli

import maniplab as ml
from maniplab.actuators.hydraulic import chambers
from maniplab.actuators.hydraulic.hose import Hose, effective_bulk_modulus, hose_volume
from maniplab.spec import model_of

S = ml.signals
LIFT = "joints.lift.actuator.cylinder"
OIL = 1.0e9  # patu655's lift: bulk_modulus (Pa)
SUPPLY = 8.0e6 + 101325.0  # its supply pressure, absolute (the spec's is gauge), Pa
HOSES = {"a": {"length": 3.0, "inner_diameter": 0.0127, "wall_bulk_modulus": 1.5e9, "air": 0.005},
         "b": {"length": 2.0, "inner_diameter": 0.0095}}
"""A 3 m 1/2" hose with a swelling wall and 0.5 % air to the cap side, a rigid 2 m 3/8" one to
the rod side."""


def by_hand(length: float, diameter: float, wall: float | None = None, air: float = 0.0) -> float:
    """V_h β_oil/β_e, m³, written out here: V_h = π d²/4 L; 1/β_e = 1/β_oil + 1/β_wall +
    ε/(1.4 p) with ε the air's volume fraction after adiabatic compression from 1 atm to the
    supply's absolute pressure p (Merritt 1967, §2.3)."""
    volume = math.pi * diameter**2 / 4.0 * length
    air_volume = air * (101325.0 / SUPPLY) ** (1.0 / 1.4)
    eps = air_volume / (1.0 - air + air_volume)
    compliance = 1.0 / OIL + (1.0 / wall if wall else 0.0) + eps / (1.4 * SUPPLY)
    return volume * OIL * compliance


def test_the_volume_of_a_hose_is_the_bore_times_the_length() -> None:
    # a 3 m 1/2" hose: pi/4 * 0.0127² * 3 = 0.380 L
    assert hose_volume(3.0, 0.0127) == pytest.approx(3.8003e-4, rel=1e-4)
    assert Hose(length=3.0, inner_diameter=0.0127).volume == pytest.approx(3.8003e-4, rel=1e-4)


def test_the_effective_bulk_modulus_is_the_series_of_oil_wall_and_air() -> None:
    # a rigid wall and no air: the oil's, exactly
    assert effective_bulk_modulus(1.4e9, 2e7) == 1.4e9
    assert Hose(length=1.0, inner_diameter=0.01).bulk_modulus(1.4e9, 2e7) == 1.4e9
    # oil 1.65 GPa, a wall of 0.7 GPa (PATU's hoses): 1/(1/1.65 + 1/0.7) GPa = 0.4915 GPa
    assert effective_bulk_modulus(1.65e9, 8e6, wall=0.7e9) == pytest.approx(0.49149e9, rel=1e-4)
    # air at the supply's pressure: 0.5 % free air is 2.2e-4 of the volume at 8.1 MPa, and adds
    # 2.2e-4 / (1.4 * 8.1 MPa) = 1.94e-11 1/Pa to the oil's 1e-9
    hose = Hose(length=3.0, inner_diameter=0.0127, air=0.005)
    assert 1.0 / hose.bulk_modulus(OIL, SUPPLY) - 1.0 / OIL == pytest.approx(1.940e-11, rel=1e-3)


def test_the_air_term_follows_the_compression_of_oil_and_air() -> None:
    """An independent derivation: a litre of oil with 1 % free air (at 1 atm), compressed to p,
    the oil by its bulk modulus and the air adiabatically (p V^1.4 constant); -V dp/dV by a
    central difference is the mixture's exact modulus, 1/β = (1 - ε)/β_oil + ε/(1.4 p). Merritt's
    form keeps 1/β_oil whole, so its 1/β_e exceeds the exact one by ε/β_oil. (The oil's volume
    at p is taken as at 1 atm, as the hose's ε does: its own compression would change ε by
    3e-4 of itself.)"""
    oil, air, p = 1.5e9, 0.01, 5.0e5

    def volume(pressure: float) -> tuple[float, float]:
        liquid = (1.0 - air) * math.exp(-(pressure - p) / oil)
        gas = air * (101325.0 / pressure) ** (1.0 / 1.4)
        return liquid, gas

    h = 1.0
    (l1, g1), (l2, g2), (l0, g0) = volume(p + h), volume(p - h), volume(p)
    exact = -(l0 + g0) * 2.0 * h / ((l1 + g1) - (l2 + g2))
    merritt = effective_bulk_modulus(oil, p, air=air)
    eps = g0 / (l0 + g0)
    assert exact < 0.2 * oil  # the air dominates at 0.5 MPa
    assert 1.0 / merritt - 1.0 / exact == pytest.approx(eps / oil, rel=1e-3)


def test_without_hoses_the_dead_volumes_are_the_users() -> None:
    lift = ml.builtin_spec("patu655").joint("lift").actuator
    assert lift.cylinder.hoses is None
    assert lift.chamber_dead_volumes == lift.cylinder.dead_volumes == (2.5e-4, 2.5e-4)


@pytest.fixture(scope="module")
def patu() -> dict[str, ml.ManipulatorSpec]:
    base = ml.builtin_spec("patu655")
    extra = (by_hand(3.0, 0.0127, 1.5e9, 0.005), by_hand(2.0, 0.0095))
    return {"plain": base,
            "hoses": base.with_overrides({f"{LIFT}.hoses": HOSES}),
            "by hand": base.with_overrides({f"{LIFT}.dead_volumes": [2.5e-4 + extra[0],
                                                                    2.5e-4 + extra[1]]})}


def test_the_hoses_add_their_equivalent_dead_volumes(patu: dict[str, ml.ManipulatorSpec]) -> None:
    lift = patu["hoses"].joint("lift").actuator
    assert lift.cylinder.dead_volumes == (2.5e-4, 2.5e-4)  # what the user wrote
    assert lift.chamber_dead_volumes == pytest.approx(
        patu["by hand"].joint("lift").actuator.cylinder.dead_volumes, rel=1e-14)
    # the 3 m 1/2" hose with its wall and air: 0.380 L × (1 + 1/1.5 + 0.019) = 0.641 L of oil
    assert lift.chamber_dead_volumes[0] - 2.5e-4 == pytest.approx(6.408e-4, rel=1e-3)
    config = chambers.plugin_config(lift)  # the exported MJCF's engine plugin
    assert (config["dead_a"], config["dead_b"]) == lift.chamber_dead_volumes


def test_a_hose_simulates_exactly_as_its_equivalent_dead_volume(
        patu: dict[str, ml.ManipulatorSpec]) -> None:
    """The lift's valve opened and reversed: with the hoses, pA, pB and q are the runs of the
    spec without hoses whose dead volumes were raised by V_h β_oil/β_e computed in this file, and
    not those of the spec without them."""
    lift = {"lift": S.step(0.5, 0.1) + S.step(-1.0, 0.5)}
    runs = {k: ml.simulate(spec, inputs=lift, duration=0.9, dt=1e-3, progress=False,
                           initial={"q": [0.0, -0.3, 1.2], "dP": "gravity"})
            for k, spec in patu.items()}
    for signal in ("pA", "pB", "q"):  # lift and tilt (the slew is a lumped drive: no pA, pB)
        hose, hand = runs["hoses"][signal][:, 1:], runs["by hand"][signal][:, 1:]
        scale = float(np.ptp(hand[:, 0]))
        np.testing.assert_allclose(hose, hand, rtol=0.0, atol=1e-12 * scale)  # measured: equal
    # without the hoses the oil spring is stiffer: the chamber pressures differ by bars
    assert np.abs(runs["plain"]["pA"][:, 1] - runs["hoses"]["pA"][:, 1]).max() > 1e5


def test_a_blocked_chamber_rises_at_the_flow_over_the_total_compliance(
        patu: dict[str, ml.ManipulatorSpec]) -> None:
    """The valve closed and the piston pushed in at 0.1 m/s: the cap side's pressure rises at
    Q / (V_cyl/β_oil + V_h/β_e), Q = A_A v, V_cyl the chamber's own volume at that stroke."""
    spec = patu["hoses"].with_overrides({"joints.lift.actuator.leakage": 0.0})
    p = spec.joint("lift").actuator
    law = chambers.chambers_law(p)
    stroke, speed = 0.2, -0.1  # m of travel, m/s (retracting: the cap side is compressed)
    rates = chambers.rates(law, np.array([3e6, 2e6, 0.0]), 0.0, p.cylinder.min_length + stroke,
                           speed)
    cap = math.pi * 0.1**2 / 4.0
    hose = math.pi * 0.0127**2 / 4.0 * 3.0
    eps = 0.005 * (101325.0 / SUPPLY) ** (1 / 1.4) / (1.0 - 0.005 + 0.005 * (101325.0 / SUPPLY)
                                                      ** (1 / 1.4))
    beta_e = 1.0 / (1.0 / OIL + 1.0 / 1.5e9 + eps / (1.4 * SUPPLY))
    compliance = (2.5e-4 + cap * stroke) / OIL + hose / beta_e
    assert rates[0] == pytest.approx(-cap * speed / compliance, rel=1e-12)


def test_the_oil_spring_softens_with_the_hoses_compliance(
        patu: dict[str, ml.ManipulatorSpec]) -> None:
    """E (A_A²/V_A + A_B²/V_B) r² with the hoses is the two columns' stiffness A²/compliance, the
    compliance of each chamber and its hose added: the oil spring's frequency falls as the square
    root of the stiffnesses' ratio."""
    q = -0.3
    plain, hoses = (model_of(patu[k].joint("lift")) for k in ("plain", "hoses"))
    c = patu["plain"].joint("lift").actuator.cylinder
    s, r = float(plain.geometry.length(q)), float(plain.geometry.arm(q))
    cap, rod = math.pi * 0.1**2 / 4.0, math.pi * (0.1**2 - 0.056**2) / 4.0
    va = 2.5e-4 + cap * (s - c.min_length)
    vb = 2.5e-4 + rod * (c.min_length + c.stroke - s)
    stiffness = OIL * (cap**2 / va + rod**2 / vb) * r**2
    softer = (cap**2 / (va / OIL + by_hand(3.0, 0.0127, 1.5e9, 0.005) / OIL)
              + rod**2 / (vb / OIL + by_hand(2.0, 0.0095) / OIL)) * r**2
    assert plain.stiffness(q) == pytest.approx(stiffness, rel=1e-12)
    assert hoses.stiffness(q) == pytest.approx(softer, rel=1e-12)
    # 0.85 at this pose, where the chambers hold 2.9 and 1.3 L: the oil spring rings 8 % lower
    assert 0.8 < softer / stiffness < 0.9


def test_info_shows_what_the_hoses_add(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                       patu: dict[str, ml.ManipulatorSpec]) -> None:
    path = tmp_path / "patu.yaml"
    patu["hoses"].dump(path)
    code, out, err = run_cli(capsys, "info", str(path))
    assert code == 0, err
    line = next(x for x in out.splitlines() if x.strip().startswith("hoses"))
    assert f"+{by_hand(3.0, 0.0127, 1.5e9, 0.005) * 1e3:.4g} L" in line
    assert f"dead volumes {(2.5e-4 + by_hand(3.0, 0.0127, 1.5e9, 0.005)) * 1e3:.4g}" in line


@pytest.mark.parametrize(("hose", "field", "words"), [
    ({"length": -3.0, "inner_diameter": 0.0127}, "hoses.a.length", "> 0"),
    ({"length": 3.0, "inner_diameter": 0.0127, "air": 0.2}, "hoses.a.air", "< 0.2"),
    ({"length": 3.0, "inner_diameter": 0.0127, "colour": "red"}, "hoses.a.colour",
     "unknown key"),
    ({"length": 3.0}, "hoses.a.inner_diameter", "missing"),
])
def test_a_bad_hose_is_one_line_naming_the_joint_and_field(
        capsys: pytest.CaptureFixture[str], tmp_path: Path, hose: dict, field: str,
        words: str) -> None:
    """In an override, and in a spec file that ``maniplab validate`` reads."""
    base = ml.builtin_spec("patu655")
    with pytest.raises(ml.SpecError) as info:
        base.with_overrides({f"{LIFT}.hoses.a": hose})
    line = str(info.value)
    assert "\n" not in line and info.value.joint == "lift"
    assert info.value.field == f"actuator.cylinder.{field}" and words in line
    data = base.to_dict()
    data["joints"][1]["actuator"]["cylinder"]["hoses"] = {"a": hose}
    path = tmp_path / "patu.yaml"
    path.write_text(yaml.safe_dump(data))
    code, out, err = run_cli(capsys, "validate", str(path))
    assert code == 2, out + err
    line = err.strip()
    assert "\n" not in line and "Traceback" not in line
    assert str(path) in line and "joint lift" in line and f"'actuator.cylinder.{field}'" in line


def test_a_single_hose_field_can_be_overridden_into_a_spec_without_hoses() -> None:
    spec = ml.builtin_spec("patu655").with_overrides({
        f"{LIFT}.hoses.b.length": 4.0, f"{LIFT}.hoses.b.inner_diameter": 0.0127})
    hoses = spec.joint("lift").actuator.cylinder.hoses
    assert hoses.a is None and hoses.b == Hose(length=4.0, inner_diameter=0.0127)
    longer = spec.with_overrides({f"{LIFT}.hoses.b.length": 5.0})
    assert longer.joint("lift").actuator.chamber_dead_volumes[1] == pytest.approx(
        2.5e-4 + math.pi / 4.0 * 0.0127**2 * 5.0, rel=1e-14)
