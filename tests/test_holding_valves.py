"""Load-holding valves (issue 35): counterbalance valves and pilot-operated checks on a cylinder's
chambers, hose bursts, the lowering oscillation. Against the documented law written here (the
hydraulics page), an independent Radau integration, closed forms and a corpus crane."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

import maniplab as ml
from maniplab.actuators.hydraulic import chambers
from maniplab.errors import SpecError
from maniplab.sim.bursts import drops
from maniplab.sim.energy import energy_report
from maniplab.sim.errors import InputError
from maniplab.sim.lowering import oscillations
from maniplab.spec import model_of

BORE, ROD, STROKE, MIN_LENGTH = 0.08, 0.045, 0.8, 1.0
A_A = math.pi / 4.0 * BORE**2
A_B = math.pi / 4.0 * (BORE**2 - ROD**2)
PS, PT, E = 16.0e6, 0.0, 1.4e9
DEAD = 3.0e-4
MASS, G, VISCOUS = 3000.0, 9.81, 1.0e5
VALVE = {"nominal_flow": 1.0e-3, "nominal_pressure_drop": 35.0e5, "tau": 0.01, "flow_ratio": 0.3}
CBV = {"type": "counterbalance", "setting": 7.6e6, "pilot_ratio": 2.0, "nominal_flow": 1.0e-3,
       "band": 2.0e6}
U, T_STEP, Q0 = -0.5, 0.1, 0.7
CRANE = Path(__file__).parent / "arms" / "knuckle_crane.yaml"


def lift(holding: dict | None, **valve: object) -> ml.ManipulatorSpec:
    """A 3 t load on a vertical slide held by an inline cylinder below it (s = q + 1 m), the
    cap side carrying the load, with a viscous guide (1e5 N s/m)."""
    actuator = {"type": "hydraulic", "valve": {**VALVE, **valve}, "supply_pressure": PS,
                "tank_pressure": PT, "bulk_modulus": E,
                "cylinder": {"pins": {"parent": [0.0, 0.0, -MIN_LENGTH], "child": [0.0, 0.0, 0.0]},
                             "bore": BORE, "rod": ROD, "min_length": MIN_LENGTH,
                             "stroke": STROKE, "dead_volumes": [DEAD, DEAD]}}
    if holding is not None:
        actuator["holding"] = holding
    return ml.ManipulatorSpec.from_dict({
        "name": "lift", "gravity": [0.0, 0.0, -G],
        "joints": [{"name": "z", "type": "P", "axis": "z", "limits": [0.0, STROKE],
                    "body": {"mass": MASS}, "actuator": actuator,
                    "friction": {"model": "hybrid", "viscous": VISCOUS}}]})


HELD = {"q": [Q0], "pA": [MASS * G / A_A], "pB": [PT]}
"""At rest at Q0, the cap side holding the load, the rod side at tank."""

# the documented law, written here: each edge K = Q_n / sqrt(drop per edge), laminar below 5 % of
# it; the B port's edges flow_ratio times the A port's; the holding valve K_h = Q_h / sqrt(dp_h)
EDGE_DROP = VALVE["nominal_pressure_drop"] / 2.0
K_A = VALVE["nominal_flow"] / math.sqrt(EDGE_DROP)
K_B = VALVE["flow_ratio"] * K_A
LAMINAR = 0.05 * EDGE_DROP
K_H = CBV["nominal_flow"] / math.sqrt(1.0e6)


def root(dp: float) -> float:
    return dp / (dp * dp + LAMINAR**2) ** 0.25


def ramp(e: float, d: float = 0.05) -> float:
    """min(max(e, 0), 1) with its corners rounded by parabolas over ±d."""
    if e <= -d or e >= 1.0 + d:
        return 0.0 if e <= -d else 1.0
    if e < d:
        return (e + d) ** 2 / (4.0 * d)
    if e > 1.0 - d:
        return 1.0 - (1.0 + d - e) ** 2 / (4.0 * d)
    return e


def cbv_opening(pa: float, pb: float) -> float:
    excess = (pa - PT) + CBV["pilot_ratio"] * (pb - PT) - CBV["setting"]
    return ramp(excess / CBV["band"])


def way_out(pa: float, pb: float, x: float) -> float:
    """A -> T through the meter-out edge and the counterbalance valve in series."""
    edge, valve = K_A * max(-x, 0.0), K_H * cbv_opening(pa, pb)
    if edge == 0.0 or valve == 0.0:
        return 0.0
    return edge * valve / math.hypot(edge, valve) * root(pa - PT)


def rhs(_t: float, y: np.ndarray, u: float) -> list[float]:
    """(q, v, pA, pB, x)' of the load on its cylinder, the valve at command u."""
    q, v, pa, pb, x = y
    va, vb = DEAD + A_A * q, DEAD + A_B * (STROKE - q)
    into_b = K_B * max(-x, 0.0) * (root(PS - pb) if PS > pb else 0.0)
    return [v, (pa * A_A - pb * A_B - MASS * G - VISCOUS * v) / MASS,
            E / va * (-way_out(pa, pb, x) - A_A * v),
            E / vb * (into_b + A_B * v),
            (u - x) / VALVE["tau"]]


def steady(x: float = U) -> tuple[float, float, float]:
    """(v, pA, pB) of steady lowering at spool x, the closed form: the rod side's inflow A_B v
    through the P->B edge, the cap side's outflow A_A v through the meter-out edge and the
    counterbalance valve in series, whose opening z = (pA + R pB - p_c) / band (so that
    pA + R pB = p_c + z band), and the force pA A_A - pB A_B = m g + c v."""

    def balance(z: np.ndarray) -> list[float]:
        speed, p_a, p_b = z[0], z[1] * 1e6, z[2] * 1e6
        return [(K_B * -x * root(PS - p_b) + A_B * speed) * 1e4,
                (way_out(p_a, p_b, x) + A_A * speed) * 1e4,
                (p_a * A_A - p_b * A_B - MASS * G - VISCOUS * speed) * 1e-4]

    speed, p_a, p_b = fsolve(balance, [-0.1, 6.0, 1.0], xtol=1e-14)
    return float(speed), float(p_a * 1e6), float(p_b * 1e6)


@functools.cache
def lowered(dt: float, duration: float) -> ml.Run:
    return ml.simulate(lift({"a": CBV}), duration=duration, dt=dt, initial=HELD,
                       inputs={"z": ml.signals.step(U, T_STEP)}, sample_dt=1e-3)


def test_lowering_through_a_counterbalance_valve_matches_an_independent_integration() -> None:
    """Lowering, from the steady state with the rod side 3 bar above it: q, pA and pB of the
    plant at 20 µs (every millisecond) against Radau (rtol 1e-10) of the load, the chambers, the
    valve's edges and the counterbalance valve written here, over the transient in which the
    valve opens wider and closes back (the rod side stays above tank: the anti-cavitation valve,
    which the reference leaves out, never acts). Measured, pA: 7.6e-5 of its range at 0.1 ms,
    1.9e-5 at the derived 50 µs, 3.0e-6 at 20 µs, 7.6e-7 at 10 µs (second order)."""
    duration = 1.0
    v, pa, pb = steady()
    y0 = [Q0, v, pa, pb + 3.0e5, U]
    run = ml.simulate(lift({"a": CBV}), duration=duration, dt=2e-5, sample_dt=1e-3,
                      initial={"q": [Q0], "qd": [v], "pA": [pa], "pB": [pb + 3.0e5],
                               "spool": [U]}, inputs={"z": U})
    opts = {"method": "Radau", "rtol": 1e-10, "atol": [1e-12, 1e-12, 1e-3, 1e-3, 1e-12],
            "dense_output": True}
    reference = solve_ivp(rhs, (0.0, duration), y0, args=(U,), **opts)
    assert reference.success
    ref = reference.sol(run.t)
    pb_run = run["pB"][:, 0]
    assert np.all(pb_run > PT) and np.ptp(run["hold_a"][:, 0]) > 0.05
    for name, sim, exact in (("q", run.q[:, 0], ref[0]), ("pA", run["pA"][:, 0], ref[2]),
                             ("pB", pb_run, ref[3])):
        error = np.max(np.abs(sim - exact)) / np.ptp(exact)
        assert error < 1e-5, f"{name}: {error:.3g} of its range"


def test_steady_lowering_balances_crack_pressure_pilot_ratio_and_load() -> None:
    """Lowered from rest long enough to settle (the valve opening from shut, the rod side
    cavitating for a moment as the load first runs ahead), the load sinks at the speed and the
    chambers sit at the pressures of the closed form (:func:`steady`), to 1e-6; the
    counterbalance valve meters (its opening within 0.1..0.9) and takes its share of the energy,
    whose balance closes."""
    run = lowered(5e-5, 4.0)
    speed, p_a, p_b = steady()
    assert 0.1 < cbv_opening(p_a, p_b) < 0.9
    assert run.qd[-1, 0] == pytest.approx(speed, rel=1e-6)
    assert run["pA"][-1, 0] == pytest.approx(p_a, rel=1e-6)
    assert run["pB"][-1, 0] == pytest.approx(p_b, rel=1e-6)
    assert p_a + CBV["pilot_ratio"] * p_b == pytest.approx(
        CBV["setting"] + cbv_opening(p_a, p_b) * CBV["band"], rel=1e-12)
    report = energy_report(run)
    assert report.total("holding") > 0.0
    assert abs(report.residual) < 1e-9 * report.pump


@pytest.mark.parametrize("leakage", [0.0, 1.0e-13])
def test_a_burst_line_leaves_the_load_held_but_for_the_seat_leakage(leakage: float) -> None:
    """The valve closed and the cap side's hose burst at 0.2 s: with a counterbalance valve the
    load stays (0: to 1e-9 m over 5 s) or sinks by the seat's leakage L (pA - Pt) alone, at
    v = L (pA - Pt) / A_A (to 1 %); without one it falls, and the run fails its health check
    naming the joint and the line."""
    spec = lift({"a": {**CBV, "leakage": leakage}})
    run = ml.simulate(spec, duration=5.2, dt=5e-4, initial=HELD, bursts="z:a@0.2")
    q = run.q[:, 0]
    assert run.meta["bursts"] == ["z:a@0.2"]
    expected = leakage * (HELD["pA"][0] - PT) / A_A * 5.0
    assert q[0] - q[-1] == pytest.approx(expected, rel=0.01, abs=1e-9)
    assert [f for f in run.health.findings if f.check == "burst"] == []
    bare = ml.simulate(lift(None), duration=1.0, dt=5e-4, initial=HELD, bursts="z:a@0.2")
    assert bare.q[0, 0] - bare.q[-1, 0] > 0.1
    (failure,) = [f for f in bare.health.findings if f.check == "burst"]
    assert failure.joint == "z" and "line A burst at 0.2 s" in failure.cause
    assert bare.health.verdict == "failed"


def test_a_pilot_operated_check_opens_at_its_pilot_ratio() -> None:
    """A pilot-operated check (ratio 4, spring 5 bar) holds the cap side until the pilot (the rod
    side) reaches (pA - Pt) / R + p_s: the law passes no oil 0.1 bar below that and passes oil
    0.1 bar above (its band 0.5 bar, rounded over 5 % of it), the spool open to tank; a
    counterbalance valve cracks where pA + R pB reaches its setting."""
    check = {"type": "pilot_check", "pilot_ratio": 4.0, "setting": 5.0e5, "nominal_flow": 1.0e-3,
             "band": 5.0e5}
    law = model_of(lift({"a": check}).joints[0]).law
    pa = 6.0e6
    opens = PT + (pa - PT) / 4.0 + 5.0e5
    shut, open_ = (chambers.flows(law, np.array([pa, pilot, -1.0]), MIN_LENGTH + 0.4)[0]
                   for pilot in (opens - 1e4, opens + 1e4))
    assert shut == 0.0 and open_ < -1e-6
    law = model_of(lift({"a": CBV}).joints[0]).law
    cracks = (CBV["setting"] - (pa - PT)) / CBV["pilot_ratio"] + PT
    rounded = 0.05 * CBV["band"] / CBV["pilot_ratio"]  # the opening's corner, in pilot pressure
    shut, open_ = (chambers.flows(law, np.array([pa, pilot, -1.0]), MIN_LENGTH + 0.4)[0]
                   for pilot in (cracks - rounded - 1e4, cracks + 1e4))
    assert shut == 0.0 and open_ < -1e-6


def test_a_burst_on_the_corpus_crane_is_held_by_its_counterbalance_valves() -> None:
    """The forestry crane of the corpus at rest, its boom's cap-side hose burst at 0.5 s: its
    counterbalance valve holds the boom (the piston moves less than 1 mm in 5 s: the piston's
    own leakage); without the valve the boom falls and the run fails, naming it."""
    start = {"q": {"boom": -0.3, "jib": 1.2, "telescope": 0.5}, "dP": "gravity"}
    held = ml.simulate(CRANE, duration=5.5, initial=start, bursts="boom:a@0.5")
    ((_, moved, watched),) = drops(held)
    assert moved < 1e-3 and watched == pytest.approx(5.0, abs=0.01)
    assert held.health.verdict != "failed"
    fallen = ml.simulate(CRANE, duration=1.5, initial=start, bursts="boom:a@0.5",
                         overrides={"joints.boom.actuator.holding": None})
    ((_, moved, _),) = drops(fallen)
    assert moved > 0.1
    assert fallen.health.findings[0].check == "burst" and fallen.health.verdict == "failed"


@pytest.mark.parametrize("ratio, oscillates", [(1.0, False), (6.0, True)])
def test_the_lowering_oscillation_is_reported_at_a_high_pilot_ratio(ratio: float,
                                                                    oscillates: bool) -> None:
    """The crane's boom lowered under a pressure-compensated section: at a 1:1 pilot ratio it
    settles; at 6:1 its cap side's pressure swings at a few hertz and the verdict says so."""
    over = {"joints.boom.actuator.holding.a.pilot_ratio": ratio,
            "joints.boom.actuator.valve.compensator_margin": 1.5e6}
    run = ml.simulate(CRANE, duration=2.5, overrides=over,
                      initial={"q": {"boom": -0.6, "jib": 1.2, "telescope": 0.5},
                               "dP": "gravity"},
                      inputs={"boom": ml.signals.step(-0.15, 0.3)})
    found = [f for f in run.health.findings if f.check == "lowering"]
    assert bool(found) == oscillates
    if oscillates:
        assert found[0].joint == "boom" and "6:1" in found[0].advice
        assert 2.0 < oscillations(run)[0].frequency < 12.0


def test_the_load_chart_rates_holding_at_the_counterbalance_setting() -> None:
    """A counterbalance valve set below the relief caps the holding chamber at its setting (its
    pilot at tank): the push the cylinder holds is (Pt + p_c) A_A - Pt A_B."""
    model = model_of(lift({"a": {**CBV, "setting": 5.0e6}}).joints[0])
    low, high = model.rated_holding_range(0.3, 12.0e6)
    assert high == pytest.approx((PT + 5.0e6) * A_A - PT * A_B, rel=1e-12)
    assert low == pytest.approx(PT * A_A - 12.0e6 * A_B, rel=1e-12)


@pytest.mark.parametrize("change, words", [
    ({"type": "counterbalance", "pilot_ratio": 3.0, "nominal_flow": 1e-3}, "setting"),
    ({**CBV, "pilot_ratio": 0.0}, "pilot_ratio"),
    ({**CBV, "type": "overcentre"}, "type"),
])
def test_a_bad_holding_valve_is_one_line(change: dict, words: str) -> None:
    with pytest.raises(SpecError, match=words) as err:
        ml.Plant(lift({"a": change}))
    assert "\n" not in str(err.value) and "holding" in str(err.value)


@pytest.mark.parametrize("burst, words", [
    ("z:c@1", "JOINT:LINE@TIME"), ("z:a@-1", "positive"), ("y:a@1", "no joint"),
    ("z:a@soon", "not a number"),
])
def test_a_bad_burst_is_one_line(burst: str, words: str) -> None:
    with pytest.raises(InputError, match=words) as err:
        ml.simulate(lift({"a": CBV}), duration=0.01, bursts=burst)
    assert "\n" not in str(err.value)


def test_the_cascade_lowers_the_crane_through_its_counterbalance_valves() -> None:
    """The cascade's drive inverts each section with its counterbalance valve in the line (the
    same law), so it asks for the pilot pressure lowering needs: the corpus crane's boom and jib
    lowered by a 4 s move end within 0.1 mm of the target, the run healthy, the boom's valve
    held open by the rod side's pressure all the way down (the section meters)."""
    from maniplab.control.move import run_move
    from maniplab.model.analytic import AnalyticModel

    spec = ml.resolve_spec(CRANE)
    start, end = [0.0, -0.6, 1.2, 0.5, 0.0], [0.0, -0.2, 1.6, 0.5, 0.0]  # the boom down
    target = AnalyticModel(spec).fk(end)[:3, 3]
    result = run_move(spec, list(target), start=start, duration=4.0)
    assert result.metrics.to_dict()["final_error_mm"] < 0.1
    assert result.health.verdict == "ok"
    run, k = result.run, spec.joint_index("boom")
    lowering = run.qd[:, k] > 0.02
    assert lowering.sum() > 1000
    assert np.all(run["hold_a"][lowering, k] > 0.5)
