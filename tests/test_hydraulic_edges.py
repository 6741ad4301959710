"""The pinned two-chamber cylinder at the edges ``tests/test_cylinder_physics.py`` stays away
from, each against a reference written here: a chamber held at tank pressure by its
anti-cavitation check valve (an integration of the constrained system with events), an
asymmetric valve on a shared pump that cannot feed it (the pump's flow against the chambers'),
and a retraction fed by a flow-limited pump (the piston's speed Q_max / A_B).

Each test names, in its docstring, the bug planted in ``maniplab_native`` (in a copy of the
repository) that it was seen to catch."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve
from test_cylinder_physics import (
    A_A,
    A_B,
    BORE,
    DEAD,
    PS,
    PT,
    Q0,
    RELIEF,
    ROD,
    VALVE,
    Hydraulics,
    boom,
    initial,
)

import maniplab as ml

# --- 1. a chamber at tank pressure: the anti-cavitation valve -----------------------------------

RATIO = 0.2
"""The valve's B edges at a fifth of its A edges: lowering, the cap side pushes oil out through
A->T faster than P->B can fill the growing rod side, whose pressure falls to tank."""
T_OPEN, T_CLOSE, T_END = 0.05, 0.5, 0.8
LOWER = ml.signals.step(-1.0, t0=T_OPEN) + ml.signals.step(1.0, t0=T_CLOSE)


def _clamped_reference(law: Hydraulics, z0: np.ndarray, pieces: list[tuple[float, float, float]]
                       ) -> list[tuple[float, float, object]]:
    """Radau of the boom whose chambers are held at tank when they would fall below it (the
    ideal check valve as a constraint): a chamber whose pressure reaches Pt falling stays there
    (its rate set to 0) until the unconstrained rate turns positive, then follows its law again.
    Each switch is an event; ``pieces`` are (t0, t1, valve current). Returns (t0, t1, dense
    solution) per stretch."""
    opts = {"method": "Radau", "rtol": 1e-10, "atol": [1e-12, 1e-12, 1e-4, 1e-4, 1e-12],
            "dense_output": True}
    out = []
    z = np.array(z0, dtype=float)
    for t0, t1, iv in pieces:
        t = t0
        rates = law.boom_rhs(t, z, iv)  # a chamber at tank: held while its law would lower it
        held = [z[2 + k] <= PT and rates[2 + k] < 0.0 for k in (0, 1)]
        while t < t1:

            def rhs(_t: float, y: np.ndarray, frozen: tuple = tuple(held), iv: float = iv):
                rates = law.boom_rhs(_t, y, iv)
                return [0.0 if k in (2, 3) and frozen[k - 2] else r
                        for k, r in enumerate(rates)]

            events = []
            for k in (0, 1):
                if held[k]:  # leaves tank when its own law would raise it
                    def event(_t, y, k=k, iv=iv):
                        return law.boom_rhs(_t, y, iv)[2 + k]
                    event.direction = 1.0
                else:  # reaches tank falling
                    def event(_t, y, k=k):  # (1 mPa below: one at tank and still, stays)
                        return y[2 + k] - (PT - 1e-3)
                    event.direction = -1.0
                event.terminal = True
                events.append(event)
            sol = solve_ivp(rhs, (t, t1), z, events=events, **opts)
            assert sol.status in (0, 1), sol.message
            out.append((t, float(sol.t[-1]), sol.sol))
            z, t = sol.y[:, -1].copy(), float(sol.t[-1])
            for k in (0, 1):
                if len(sol.t_events[k]):
                    held[k] = not held[k]
                    z[2 + k] = PT
    return out


@functools.cache
def _cavitating() -> tuple[ml.Run, list]:
    spec = boom(valve={**VALVE, "flow_ratio": RATIO})
    law = Hydraulics.of(spec["joints"][0]["actuator"])
    run = ml.simulate(ml.ManipulatorSpec.from_dict(spec), inputs={"luff": LOWER},
                      duration=T_END, initial=initial(Q0))
    start = initial(Q0)
    z0 = np.array([Q0, 0.0, start["pA"][0], start["pB"][0], start["spool"][0]])
    ref = _clamped_reference(law, z0, [(0.0, T_OPEN, 0.0), (T_OPEN, T_CLOSE, -1.0),
                                       (T_CLOSE, T_END, 0.0)])
    return run, ref


def _sample(ref: list, t: np.ndarray) -> np.ndarray:
    """The reference's states at the times t, (5, len(t))."""
    out = np.empty((5, len(t)))
    for t0, t1, sol in ref:
        inside = (t >= t0) & (t <= t1)
        out[:, inside] = sol(t[inside])
    return out


def test_a_boom_lowered_fast_holds_its_rod_side_at_tank() -> None:
    """Lowered with the valve wide open backwards, the rod side's pressure falls to tank and
    stays there (its check valve feeds the oil P->B cannot) until the valve closes and the
    stopping boom compresses it again. Against Radau of the constrained system written here:
    the stretch at tank within 3 ms of the reference's events, q within 1e-4 of its travel, pA
    and pB within 3e-3 of their ranges at the derived step (the plant clamps after each step: a
    projection of the same constraint; measured 4.5e-5, 2.0e-3 and 2.5e-3: this wide-open
    lowering into cavitation is harsher than the excitation the step is derived on, the one
    documented case beyond 1e-3).

    Planted bug it catches: ``advance`` in cylinder.c without the clamp (the pressures left
    below tank): pB falls to -4.7 MPa, 3.4 times its range off the reference, q 3 % off."""
    run, ref = _cavitating()
    t, q, pa, pb = run.t, run.q[:, 0], run["pA"][:, 0], run["pB"][:, 0]
    assert len(ref) == 5  # closed, opening, held at tank, closing, freed: the events happened
    entry, exit_ = ref[1][1], ref[3][1]
    at_tank = t[(pb <= PT + 1.0) & (t > T_OPEN)]
    assert at_tank[0] == pytest.approx(entry, abs=3e-3) and at_tank[-1] == pytest.approx(
        exit_, abs=3e-3)
    assert np.all(pb[(t > entry + 2e-3) & (t < exit_ - 2e-3)] <= PT + 1.0)  # held, not below
    assert pb.min() >= PT and np.all(pa > PT) and max(pa.max(), pb.max()) < RELIEF
    exact = _sample(ref, t)
    # measured: 4.5e-5 (q), 2.0e-3 (pA), 2.5e-3 (pB); at 0.1 ms 1.8e-6, 7.9e-5, 1.1e-4
    for name, sim, tolerance, k in (("q", q, 1e-4, 0), ("pA", pa, 3e-3, 2), ("pB", pb, 3e-3, 3)):
        error = np.max(np.abs(sim - exact[k])) / np.ptp(exact[k])
        assert error < tolerance, f"{name}: {error:.3g} of its range"


# --- 2. a shared pump that cannot feed an asymmetric valve; retraction on a flow-limited pump ----

FV = 1.0e5
"""Viscous friction of each slide, N s/m: at a steady speed the only load."""
PUMP = 1.0e-4
"""The pump's flow, m³/s (6 L/min): a twentieth of what one valve passes wide open at 8 MPa."""
HALF = 0.5
"""The valves' flow_ratio: their B edges pass half of their A edges."""


def _cylinder(child: list[float], ratio: float) -> dict:
    return {"type": "hydraulic", "valve": {**VALVE, "flow_ratio": ratio},
            "cylinder": {"pins": {"parent": [0.0, 0.0, 0.0], "child": child}, "bore": BORE,
                         "rod": ROD, "min_length": 0.5, "stroke": 0.4,
                         "dead_volumes": [DEAD, DEAD]},
            "supply_pressure": PS, "tank_pressure": PT}


def slides(ratio: float = HALF, pump: float | None = PUMP) -> ml.ManipulatorSpec:
    """Two slides, x then y on it (gravity across both), each pushed along its axis by a
    cylinder lying on it (s = q + 0.7 m, r = 1), on one pump of ``pump`` m³/s."""
    joints = [{"name": name, "type": "P", "axis": name, "limits": [-0.19, 0.19],
               "body": {"mass": mass}, "actuator": _cylinder(child, ratio),
               "friction": {"model": "hybrid", "viscous": FV}}
              for name, mass, child in (("x", 500.0, [0.7, 0.0, 0.0]),
                                        ("y", 300.0, [0.0, 0.7, 0.0]))]
    data: dict = {"name": "slides", "gravity": [0.0, 0.0, -9.81], "joints": joints}
    if pump is not None:
        data["supply"] = {"pressure": PS, "max_flow": pump}
    return ml.ManipulatorSpec.from_dict(data)


def _steady_speeds(spec: ml.ManipulatorSpec, currents: dict[str, float]) -> np.ndarray:
    """The slides' speeds (m/s), averaged over 0.5..0.9 s of a run from 1 MPa in every chamber."""
    run = ml.simulate(spec, inputs=currents, duration=1.0,
                      initial={"pA": [1e6, 1e6], "pB": [1e6, 1e6]})
    k0, k1 = np.searchsorted(run.t, [0.5, 0.9])
    return np.asarray((run.q[k1] - run.q[k0]) / (run.t[k1] - run.t[k0]))


def _steady_state(law: Hydraulics, pump: float) -> np.ndarray:
    """x extending and y retracting, both valves wide open, at steady speeds (v_x, v_y, p_s)
    solved here: each cylinder's metering edges pass its chambers' flows (A_A v in, A_B v out
    extending; A_B |v| in, A_A |v| out retracting) at the pressures that balance the friction
    (pA A_A - pB A_B = F_v v), and the two inflows use up the pump, whose pressure p_s falls
    below its setting."""
    def equations(z: np.ndarray) -> list[float]:
        vx, vy, ps, pa_x, pb_x, pa_y, pb_y = z * SCALE
        flows = [A_A * vx - law.gain_a * law.root(ps - pa_x),     # P->A, extending
                 A_B * vx - law.gain_b * law.root(pb_x - PT),     # B->T
                 -A_B * vy - law.gain_b * law.root(ps - pb_y),    # P->B, retracting (vy < 0)
                 -A_A * vy - law.gain_a * law.root(pa_y - PT),    # A->T
                 A_A * vx - A_B * vy - pump]                      # the pump's flow, used up
        forces = [pa_x * A_A - pb_x * A_B - FV * vx, pa_y * A_A - pb_y * A_B - FV * vy]
        return [f / pump for f in flows] + [f / (FV * 0.01) for f in forces]

    guess = np.array([0.01, -0.005, 1e6, 2e5, 2e5, 1e5, 2e5]) / SCALE
    z, _, found, message = fsolve(equations, guess, full_output=True, xtol=1e-12)
    assert found == 1, message
    return np.asarray(z * SCALE)[:3]


SCALE = np.array([1e-2, 1e-2, 1e6, 1e6, 1e6, 1e6, 1e6])


def test_an_asymmetric_valve_on_a_starved_pump_shares_its_flow_as_solved_here() -> None:
    """Valves with flow_ratio 0.5 on a 6 L/min pump: x extends (its A edges meter) while y
    retracts (its half-size B edges meter), both wide open. The speeds against the steady state
    solved here (the four edge laws, the force balances, the pump's flow used up): within 1e-6,
    and the inflows A_A v_x + A_B |v_y| are the pump's flow to 1e-8 (measured: 1.6e-10, 1.1e-10).

    Planted bug it catches: the pump's draw through P->B (``ml_supply_draw`` in chambers.h)
    with K_A instead of K_B (the flow ratio ignored): the pump then finds the pressure at which
    the valves would draw Q_max with full-size B edges, y gets half the oil it is counted for,
    and the inflows fall 17 % short of Q_max (x 15 %, y 25 % slow)."""
    law = Hydraulics.of(_cylinder([0.7, 0.0, 0.0], HALF))
    vx, vy, ps = _steady_state(law, PUMP)
    assert 0.0 < ps < 0.5 * PS and vx > 0.0 > vy  # starved: the pressure falls far
    speeds = _steady_speeds(slides(), {"x": 1.0, "y": -1.0})
    assert speeds == pytest.approx([vx, vy], rel=1e-6)
    assert A_A * speeds[0] - A_B * speeds[1] == pytest.approx(PUMP, rel=1e-8)


def test_retraction_on_a_flow_limited_pump_fills_the_annulus_at_the_pumps_flow() -> None:
    """y alone retracts, its valve wide open, on the 6 L/min pump: the rod side fills at the
    pump's flow, so the piston moves at Q_max / A_B (to 1e-8; measured 1.4e-11), slower than with a supply of its
    own, where the valve passes more.

    Planted bug it catches: the rod side's volume rate with the cap's area (A_A ds/dt in
    ``ml_chambers_rates_law``, chambers.h): the piston then moves at Q_max / A_A, 31 % slow
    (the other two tests fail too)."""
    speeds = _steady_speeds(slides(), {"y": -1.0})
    assert speeds[0] == pytest.approx(0.0, abs=1e-12)
    assert -speeds[1] == pytest.approx(PUMP / A_B, rel=1e-8)
    own = _steady_speeds(slides(pump=None), {"y": -1.0})
    assert -own[1] > 3.0 * PUMP / A_B
