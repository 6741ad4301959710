"""Valve sections as datasheets describe them (issue 34, part): a local pressure compensator on
the meter-in edges and meter-out edges of their own, against closed forms written here, and in
the runs that matter to a crane's designer (the lift's speed set by the spool, not the load; the
cascade tracking through the compensated valve)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import maniplab as ml
from maniplab.actuators.hydraulic import chambers
from maniplab.errors import SpecError
from maniplab.spec import model_of

MARGIN = 12.0e5
"""The compensator's margin in these tests, Pa (12 bar, a typical LS section's)."""

LIFT = "joints.lift.actuator.valve"


def compensated(**more: float) -> ml.ManipulatorSpec:
    """patu655 with a compensated lift section (and ``more`` of its valve's fields)."""
    changes = {f"{LIFT}.compensator_margin": MARGIN} | {f"{LIFT}.{k}": v for k, v in more.items()}
    return ml.builtin_spec("patu655").with_overrides(changes)


def root(dp: float, laminar: float) -> float:
    """The orifice's root, linear below the laminar transition (chambers.h's g)."""
    return dp / (dp * dp + laminar * laminar) ** 0.25


def seen(dp: float, margin: float, band: float) -> float:
    """The drop a compensated meter-in edge sees: the smooth minimum of dp and the margin over
    the band (the orifices' laminar transition)."""
    return 0.5 * (dp + margin - math.sqrt((dp - margin) ** 2 + band * band))


def test_a_compensated_edge_passes_the_same_flow_over_the_load_range_and_the_orifice_law_below():
    """Into A at full opening: K_A g(seen) with the drop the compensator lets through (the
    smooth minimum of the drop and the margin, written here); within 1 % over every load whose
    drop exceeds the margin by more than a bar (the datasheet's "flow independent of load"), the
    bare orifice's K_A g(Ps - pA) well below the margin, nothing at Ps; the meter-out edges pass
    meter_out_ratio times their port's meter-in gain, the B port flow_ratio times A's."""
    spec = compensated(flow_ratio=0.7, meter_out_ratio=1.4)
    p = spec.joint("lift").actuator
    law = model_of(spec.joint("lift")).law
    drop = 0.5 * p.valve.nominal_pressure_drop  # per edge: the rating is across the valve
    k_a = p.valve.nominal_flow / math.sqrt(drop)
    band, ps, pt = 0.05 * drop, p.supply_pressure, p.tank_pressure
    s = law.min_length

    def into_a(pa: float, x: float = 1.0) -> float:
        return float(chambers.flows(law, np.array([pa, pt, x]), s)[0])

    for pa in np.linspace(pt, ps - 1e4, 60):
        assert into_a(pa) == pytest.approx(k_a * root(seen(ps - pa, MARGIN, band), band),
                                           rel=1e-12)
    loads = np.linspace(pt, ps - MARGIN - 1e5, 40)
    flows = np.array([into_a(pa) for pa in loads])
    held = k_a * root(MARGIN, band)
    assert np.max(np.abs(flows / held - 1.0)) < 0.01
    assert into_a(ps - 0.3 * MARGIN) == pytest.approx(k_a * root(0.3 * MARGIN, band), rel=0.01)
    assert into_a(ps + 1e5) == 0.0  # the load check
    # the other edges at half opening: B→T (meter-out, out), P→B (meter-in, back), A→T
    pa, pb = 3.0e6, 2.0e6
    out = chambers.flows(law, np.array([pa, pb, 0.5]), s)
    assert out[1] == pytest.approx(-1.4 * 0.7 * k_a * 0.5 * root(pb - pt, band), rel=1e-12)
    back = chambers.flows(law, np.array([pa, pb, -0.5]), s)
    assert back[1] == pytest.approx(0.7 * k_a * 0.5 * root(seen(ps - pb, MARGIN, band), band),
                                    rel=1e-12)
    assert back[0] == pytest.approx(-1.4 * k_a * 0.5 * root(pa - pt, band), rel=1e-12)


WINDOW = (0.4, 0.7)
"""The part of each 0.8 s run whose mean flows are compared, s: after the spools opened."""


def _into_chambers(run: ml.Run, spec: ml.ManipulatorSpec, joint: str) -> tuple[float, float]:
    """The mean flows into a pinned cylinder's cap and rod sides over :data:`WINDOW`, by
    continuity from the run's signals: the piston's (A ds/dt), the oil compressed
    (V/E dp/dt) and the leakage across the piston, m³/s."""
    k = spec.joint_index(joint)
    p = spec.joint(joint).actuator
    c, geometry = p.cylinder, model_of(spec.joint(joint)).geometry
    q, qd, pa, pb = run.q[:, k], run.qd[:, k], run["pA"][:, k], run["pB"][:, k]
    travel = geometry.length(q) - c.min_length
    sdot, leak = geometry.arm(q) * qd, p.leakage * (pa - pb)
    into_a = (c.cap_area * sdot + (c.dead_volumes[0] + c.cap_area * travel) / p.bulk_modulus
              * np.gradient(pa, run.t) + leak)
    into_b = (-c.rod_area * sdot + (c.dead_volumes[1] + c.rod_area * (c.stroke - travel))
              / p.bulk_modulus * np.gradient(pb, run.t) - leak)
    window = (run.t > WINDOW[0]) & (run.t < WINDOW[1])
    return float(np.mean(into_a[window])), float(np.mean(into_b[window]))


def _lift_flow(spec: ml.ManipulatorSpec, payload: float) -> tuple[float, float]:
    """The flow into the lift's cap side over :data:`WINDOW` of a full-opening lift
    (:func:`_into_chambers`), m³/s, and the least drop from supply to the cap side then, Pa."""
    heavy = spec.with_overrides({"end_effector.mass": payload})
    run = ml.simulate(heavy, inputs={"lift": 1.0}, duration=0.8,
                      initial={"q": [0.0, 0.0, 1.2], "dP": "gravity"}, sample_dt=1e-3)
    window = (run.t > WINDOW[0]) & (run.t < WINDOW[1])
    pa = run["pA"][window, 1]
    return _into_chambers(run, spec, "lift")[0], float(np.min(spec.joint("lift").actuator
                                                              .supply_pressure - pa))


def test_the_lift_flow_follows_the_spool_and_not_the_load_with_a_compensator():
    """Lifting at full opening with 0 and 250 kg in the grapple (cap side at 3.1 and 6.1 MPa):
    with the compensator the section passes K_A g(margin) into the cap side whatever the load
    (asked: within 1 %; measured 1.8e-4 and 4.6e-4 below K g(margin), the compensator's
    regulation band); the bare orifice passes 21 % less to the heavy load."""
    spec = compensated()
    p = spec.joint("lift").actuator
    drop = 0.5 * p.valve.nominal_pressure_drop
    section = p.valve.nominal_flow / math.sqrt(drop) * root(MARGIN, 0.05 * drop)
    band = 0.05 * drop
    for payload in (0.0, 250.0):
        flow, least_drop = _lift_flow(spec, payload)
        assert least_drop > MARGIN  # the compensator holds throughout: within its band of it
        least = section / root(MARGIN, band) * root(seen(least_drop, MARGIN, band), band)
        assert least * (1 - 1e-3) < flow < section * (1 + 1e-3), payload
    bare = ml.builtin_spec("patu655")
    assert _lift_flow(bare, 250.0)[0] < 0.9 * _lift_flow(bare, 0.0)[0]


def test_a_short_pump_feeds_the_lighter_load_first():
    """The lift (cap side ~34 bar) and the tilt (retracting, rod side ~23 bar) at full opening,
    both sections compensated, on one pump: with ample flow each passes its section's flow; on a
    50 L/min pump the supply falls until they draw 50 L/min together, the tilt, the lighter
    load, keeps its flow (its drop still exceeds the margin) and the lift gets the rest."""
    both = {f"joints.{j}.actuator.valve.compensator_margin": MARGIN for j in ("lift", "tilt")}

    def flows(max_flow: float) -> tuple[float, float]:
        data = ml.builtin_spec("patu655").to_dict()
        data["supply"] = {"pressure": 8.0e6, "max_flow": max_flow}
        spec = ml.ManipulatorSpec.from_dict(data).with_overrides(both)
        run = ml.simulate(spec, inputs={"lift": 1.0, "tilt": -1.0}, duration=0.8,
                          initial={"q": [0.0, -0.3, 1.0], "dP": "gravity"}, sample_dt=1e-3)
        return _into_chambers(run, spec, "lift")[0], _into_chambers(run, spec, "tilt")[1]

    lift_alone, tilt_alone = flows(1.0)  # m³/s: more than both draw
    short = 8.3e-4  # 50 L/min, less than the 64.5 they draw
    assert lift_alone + tilt_alone > 1.2 * short
    lift, tilt = flows(short)
    assert lift + tilt == pytest.approx(short, rel=0.01)
    assert tilt == pytest.approx(tilt_alone, rel=0.01)
    assert lift < 0.7 * lift_alone


def test_the_cascade_tracks_a_move_through_compensated_sections():
    """The drive inverts the compensated valve (its flows at unit opening are the law's): a move
    of patu655 with both boom sections compensated ends within 5 mm of its target."""
    from maniplab.control.move import run_move

    spec = compensated().with_overrides({"joints.tilt.actuator.valve.compensator_margin": MARGIN})
    model = ml.AnalyticModel(spec)
    target = model.fk(np.array([0.3, -0.45, 1.0]))[:3, 3]
    result = run_move(spec, target, start=[0.0, -0.3, 1.2], duration=4.0, settle=1.0,
                      sample_dt=5e-3)
    final = model.fk(result.run.q[-1])[:3, 3]
    assert np.linalg.norm(final - target) < 5e-3


@pytest.mark.parametrize("value, words", [
    (8.0e6, ["compensator_margin 8e+06 Pa is not below the supply's drop to tank",
             "joint lift"]),
    (-1.0, ["joint lift", "actuator.valve.compensator_margin", "> 0"]),
    ("12 bar", ["joint lift", "actuator.valve.compensator_margin", "expected a number"]),
])
def test_a_bad_compensator_margin_is_one_line(value, words):
    with pytest.raises(SpecError) as caught:
        ml.builtin_spec("patu655").with_overrides({f"{LIFT}.compensator_margin": value})
    text = str(caught.value)
    assert "\n" not in text
    for word in words:
        assert word in text, (word, text)


def test_the_exported_mjcf_carries_the_section_and_plain_mujoco_runs_it_as_the_plant(tmp_path):
    """The compensator's margin and the meter-out gains are the engine plugin's config: plain
    MuJoCo stepping the exported file (friction none) follows the plant's run to 1e-9."""
    import mujoco

    spec = compensated(meter_out_ratio=0.8).with_overrides(
        {f"joints.{j}.friction.model": "none" for j in ("slew", "lift", "tilt")})
    plant = ml.Plant(spec)
    plant.set_state(q=[0.0, -0.3, 1.2])
    plant.balance_pressures()
    act0 = plant.data.act.copy()
    run = ml.simulate(plant, inputs={"lift": 0.8, "tilt": -0.3}, duration=0.3,
                      sample_dt=plant.dt)
    path = ml.mjcf_gen.writer.write_mjcf(spec, tmp_path / "compensated.xml")
    assert 'key="compensator_margin"' in path.read_text()
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    data.qpos[:] = [0.0, -0.3, 1.2]
    data.act[:] = act0
    q = [data.qpos.copy()]
    for u in run["ctrl"][:-1]:
        data.ctrl[:] = u
        mujoco.mj_step(model, data)
        q.append(data.qpos.copy())
    assert np.ptp(run.q[:, 1]) > 1e-3  # the lift moves
    np.testing.assert_allclose(np.array(q), run.q, rtol=0, atol=1e-9)


# --- a load-sensing pump ------------------------------------------------------------------------

PUMP_MARGIN = 15.0e5
"""The load-sensing pump's margin in these tests, Pa."""


def _on_ls_pump(**supply: float) -> ml.ManipulatorSpec:
    data = ml.builtin_spec("patu655").to_dict()
    data["supply"] = {"pressure": 8.0e6, "max_flow": 1.0, "ls_margin": PUMP_MARGIN, **supply}
    return ml.ManipulatorSpec.from_dict(data)


def test_a_load_sensing_pump_holds_the_highest_load_plus_its_margin():
    """The lift alone at full opening on an LS pump, no compensator: the pump's pressure follows
    the cap side plus its margin, so the bare orifice passes K_A g(margin) with 0 and 250 kg
    (cap side 3.1 and 6.1 MPa; 1e-3), where the constant 80 bar supply gave 87 and 69 L/min."""
    spec = _on_ls_pump()
    p = spec.joint("lift").actuator
    drop = 0.5 * p.valve.nominal_pressure_drop
    expected = p.valve.nominal_flow / math.sqrt(drop) * root(PUMP_MARGIN, 0.05 * drop)
    for payload in (0.0, 250.0):
        assert _lift_flow(spec, payload)[0] == pytest.approx(expected, rel=1e-3), payload


def test_compensated_sections_on_a_load_sensing_pump_pass_their_own_flows():
    """Lift and tilt (retracting) both compensated at 12 bar on a 15 bar LS pump: the pump
    follows the higher load (the lift's), whose compensator then sees the pump's 15 bar and
    passes K g(seen(15 bar)) (1e-3); the tilt sees more and passes K g(seen) of its larger drop,
    between that and K g(12 bar)."""
    spec = _on_ls_pump().with_overrides(
        {f"joints.{j}.actuator.valve.compensator_margin": MARGIN for j in ("lift", "tilt")})
    run = ml.simulate(spec, inputs={"lift": 1.0, "tilt": -1.0}, duration=0.8,
                      initial={"q": [0.0, -0.3, 1.0], "dP": "gravity"}, sample_dt=1e-3)
    for joint, side in (("lift", 0), ("tilt", 1)):
        v = spec.joint(joint).actuator.valve
        drop = 0.5 * v.nominal_pressure_drop
        band = 0.05 * drop
        gain = v.nominal_flow / math.sqrt(drop) * (v.flow_ratio if side else 1.0)
        at_pump_margin = gain * root(seen(PUMP_MARGIN, MARGIN, band), band)
        flow = abs(_into_chambers(run, spec, joint)[side])
        if joint == "lift":
            assert flow == pytest.approx(at_pump_margin, rel=1e-3)
        else:
            assert at_pump_margin * (1 - 1e-3) < flow < gain * root(MARGIN, band) * (1 + 1e-3)


def test_a_load_sensing_margin_above_the_cut_off_is_one_line():
    data = ml.builtin_spec("patu655").to_dict()
    data["supply"] = {"pressure": 8.0e6, "max_flow": 1e-3, "ls_margin": 9.0e6}
    with pytest.raises(SpecError) as caught:
        ml.ManipulatorSpec.from_dict(data)
    text = str(caught.value)
    assert "ls_margin 9e+06 Pa is not below the pump's cut-off pressure 8e+06 Pa" in text
    assert "\n" not in text
