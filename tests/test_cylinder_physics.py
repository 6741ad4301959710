"""The pinned two-chamber cylinder (``maniplab_native/chambers.h``, engine plugin
``maniplab.cylinder``) in the plant, against physics written here from scratch: a boom lifted
against gravity integrated independently (scipy's Radau), the lumped cylinder of eq. (4) that a
symmetric double-rod cylinder at mid-stroke reduces to, the relief valves at a stop, and the
energy balance of a boom let down through the valve's metering edges."""

from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml
from scipy.integrate import solve_ivp, trapezoid
from scipy.spatial.transform import Rotation

import maniplab as ml
from maniplab.actuators.hydraulic import PinnedCylinder, chambers
from maniplab.spec import model_of

# --- one boom luffing about y (q > 0 lowers it) on a pinned cylinder ----------------------------

G = 9.81
L, M_ROD, M_LOAD = 3.0, 150.0, 100.0
PARENT, CHILD = np.array([0.25, 0.0, -0.9]), np.array([0.9, 0.0, -0.1])
BORE, ROD, MIN_LENGTH, STROKE, DEAD = 0.1, 0.056, 0.79, 0.85, 2.0e-4
PS, PT, RELIEF = 8.0e6, 1.0e5, 9.0e6
A_A = math.pi / 4.0 * BORE**2                       # cap side: the bore, m²
A_B = math.pi / 4.0 * (BORE**2 - ROD**2)            # rod side: the annulus, m²
# about the pivot: the rod's m L²/12 about its middle plus m (L/2)², and the payload's m L²
INERTIA = M_ROD * L**2 / 12.0 + M_ROD * (L / 2.0) ** 2 + M_LOAD * L**2
MOMENT = G * (M_ROD * L / 2.0 + M_LOAD * L)          # gravity torque at q = 0, N·m
VALVE = {"nominal_flow": 9.0e-4, "nominal_pressure_drop": 35.0e5, "tau": 0.01}


def boom(*, valve: dict | None = None, **actuator: object) -> dict:
    """The boom as a spec's data, ``actuator`` overriding the actuator's keys (None drops one)."""
    cylinder = {"pins": {"parent": PARENT.tolist(), "child": CHILD.tolist()}, "bore": BORE,
                "rod": ROD, "min_length": MIN_LENGTH, "stroke": STROKE,
                "dead_volumes": [DEAD, DEAD]}
    params = {"type": "hydraulic", "cylinder": cylinder, "valve": valve or VALVE,
              "supply_pressure": PS, "tank_pressure": PT, "relief_pressure": RELIEF, **actuator}
    return {"name": "boom", "gravity": [0.0, 0.0, -G],
            "joints": [{"name": "luff", "type": "R", "axis": "y", "limits": [-1.0, 0.3],
                        "body": {"length": L, "direction": [1.0, 0.0, 0.0], "mass": M_ROD},
                        "actuator": {k: v for k, v in params.items() if v is not None},
                        "friction": {"model": "none"}}],
            "end_effector": {"mass": M_LOAD}}


def rotated_child(q: float) -> np.ndarray:
    """The child pin at q: turned about +y by q (x goes towards -z)."""
    return Rotation.from_rotvec([0.0, q, 0.0]).apply(CHILD)


def length(q: float) -> float:
    """s(q) = |R_y(q) c - p|, pin to pin, m."""
    return float(np.linalg.norm(rotated_child(q) - PARENT))


def arm(q: float) -> float:
    """r(q) = ds/dq = (R_y(q) c - p)·(ŷ × R_y(q) c) / s, m."""
    c = rotated_child(q)
    d = c - PARENT
    return float(d @ np.cross([0.0, 1.0, 0.0], c)) / float(np.linalg.norm(d))


def gravity_torque(q: float) -> float:
    """About +y: a mass m at x = l cos q, z = -l sin q under (0, 0, -g) gives (r × F)_y =
    m g l cos q, which lowers the boom."""
    return MOMENT * math.cos(q)


def potential(q: float) -> float:
    """Potential energy, J: the COGs at heights -L/2 sin q and -L sin q."""
    return -MOMENT * math.sin(q)


def volumes(s: np.ndarray | float) -> tuple:
    """(V_A, V_B) at length s, m³."""
    y = np.asarray(s) - MIN_LENGTH
    return DEAD + A_A * y, DEAD + A_B * (STROKE - y)


@dataclasses.dataclass(frozen=True)
class Hydraulics:
    """The cylinder's and valve's parameters, derived here from a spec's actuator data: each
    edge passes nominal_flow at the nominal drop per edge (half the valve's, two edges in
    series, unless per_edge), so K_A = nominal_flow / sqrt(drop per edge), K_B = flow_ratio K_A,
    the meter-out edges meter_out_ratio times their port's; laminar below 5 % of the drop per
    edge; a compensated meter-in edge sees at most the compensator's margin."""

    gain_a: float
    gain_b: float
    laminar: float
    tau: float
    current_limit: float
    bulk_modulus: float
    leakage: float
    meter_out: float = 1.0
    margin: float = math.inf

    @classmethod
    def of(cls, actuator: dict) -> Hydraulics:
        v = actuator["valve"]
        drop = v["nominal_pressure_drop"] * (1.0 if v.get("per_edge", False) else 0.5)
        gain = v["nominal_flow"] / math.sqrt(drop)
        return cls(gain, gain * v.get("flow_ratio", 1.0), 0.05 * drop, v.get("tau", 0.01),
                   v.get("current_limit", 1.0), actuator.get("bulk_modulus", 1.4e9),
                   actuator.get("leakage", 0.0), v.get("meter_out_ratio", 1.0),
                   v.get("compensator_margin") or math.inf)

    def root(self, dp: np.ndarray | float) -> np.ndarray | float:
        """The orifice's signed square root made linear below the transition, sqrt(Pa)."""
        return dp / (dp * dp + self.laminar**2) ** 0.25

    def root_in(self, dp: np.ndarray | float) -> np.ndarray | float:
        """A meter-in edge's root: no flow back into the supply; with a compensator the drop it
        sees is the smooth minimum of dp and the margin over the laminar band."""
        seen = np.asarray(dp, dtype=float)
        if math.isfinite(self.margin):
            over = seen - self.margin
            seen = 0.5 * (seen + self.margin - np.sqrt(over * over + self.laminar**2))
        return np.where(seen > 0.0, self.root(seen), 0.0)

    def supply(self, x: float, pa: float, pb: float) -> float:
        """The supply pressure the meter-in edges see at these states, Pa: PS."""
        return PS

    def edges(self, x: np.ndarray | float, pa: np.ndarray | float,
              pb: np.ndarray | float, ps: float = PS) -> tuple:
        """The four edges' flows (P->A, B->T, P->B, A->T), m³/s, at spool x and supply ps."""
        op, rev = np.maximum(x, 0.0), np.maximum(-x, 0.0)
        return (self.gain_a * op * self.root_in(ps - pa),
                self.meter_out * self.gain_b * op * self.root(pb - PT),
                self.gain_b * rev * self.root_in(ps - pb),
                self.meter_out * self.gain_a * rev * self.root(pa - PT))

    def boom_rhs(self, _t: float, z: np.ndarray, iv: float, ps: float | None = None
                 ) -> list[float]:
        """(q, q̇, pA, pB, x)' of the boom on its cylinder at valve current iv (A), the supply
        at ps (None: :meth:`supply`'s)."""
        q, v, pa, pb, x = z
        s, r = length(q), arm(q)
        sdot = r * v
        ps = self.supply(x, pa, pb) if ps is None else ps
        pa_in, b_out, pb_in, a_out = self.edges(x, pa, pb, ps)
        va, vb = volumes(s)
        leak = self.leakage * (pa - pb)
        e = self.bulk_modulus
        u = min(max(iv, -self.current_limit), self.current_limit)
        return [v, (gravity_torque(q) + (pa * A_A - pb * A_B) * r) / INERTIA,
                e / va * (pa_in - a_out - A_A * sdot - leak),
                e / vb * (pb_in - b_out + A_B * sdot + leak),
                (u / self.current_limit - x) / self.tau]


def held(q: float, pb: float = PT) -> np.ndarray:
    """(pA, pB, spool) holding the boom at rest at q (pB at tank unless given): F r = -τ_g with
    F = pA A_A - pB A_B."""
    force = -gravity_torque(q) / arm(q)
    return np.array([(force + pb * A_B) / A_A, pb, 0.0])


def initial(q: float, pb: float = PT) -> dict:
    """The run's initial state: at rest at q, held (:func:`held`)."""
    pa, pb, x = held(q, pb)
    return {"q": [q], "pA": [pa], "pB": [pb], "spool": [x]}


def test_hand_geometry_and_mass_are_the_models() -> None:
    """The inertia about the pivot, gravity torque, cylinder length and moment arm written here
    against MuJoCo's mass matrix, bias force at rest, tendon length and actuator moment."""
    model = ml.build_model(ml.ManipulatorSpec.from_dict(boom()))
    data = mujoco.MjData(model)
    for q in (-0.6, 0.1):
        data.qpos[0], data.qvel[0] = q, 0.0
        mujoco.mj_forward(model, data)
        full = np.zeros((1, 1))
        mujoco.mj_fullM(model, data, full)
        assert full[0, 0] == pytest.approx(INERTIA, rel=1e-9)
        assert -data.qfrc_bias[0] == pytest.approx(gravity_torque(q), rel=1e-9)
        assert data.ten_length[0] == pytest.approx(length(q), rel=1e-12)
        assert data.actuator_moment[0] == pytest.approx(arm(q), rel=1e-9)
    assert arm(-0.3) < 0.0  # lifting (q falling) extends the cylinder


# --- 1. lifting the boom, against Radau ---------------------------------------------------------

Q0, T_STEP, T_LIFT = -0.3, 0.1, 1.5
TOLERANCES = {None: 1e-3, 1e-4: 2e-5}
"""Largest error over the run / the reference's range over it, at the derived step (the
accuracy the step is derived for) and at 0.1 ms (the chambers' exponential step coupled to RK4
is second order: a tenth of the step, a hundredth of the error). Leaving out the orifices'
laminar transition alone costs ~5e-3."""

LIFTS = {  # actuator overrides, valve current (A), rod-side pressure held at the start (Pa)
    "brief": ({}, 0.6, PT),
    # every parameter that enters the gains, the spool and the chambers away from its default;
    # the leakage lets the boom sink a little before the valve opens, so the rod side starts
    # above tank (at tank the anti-cavitation valve would act, which the reference leaves out)
    "per-edge": ({"valve": {"nominal_flow": 9.0e-4, "nominal_pressure_drop": 20.0e5,
                            "per_edge": True, "flow_ratio": 0.6, "tau": 0.02,
                            "current_limit": 2.0},
                  "bulk_modulus": 1.0e9, "leakage": 2.0e-13}, 1.6, 1.0e6),
    # a compensated section with its own meter-out edges: the lift at full opening holds the
    # meter-in flow at K_A g(12 bar) while the supply exceeds the cap side by 12 bar
    "compensated": ({"valve": {"nominal_flow": 9.0e-4, "nominal_pressure_drop": 35.0e5,
                               "flow_ratio": 0.8, "meter_out_ratio": 0.7,
                               "compensator_margin": 12.0e5, "tau": 0.01}}, 1.0, PT),
}


@functools.cache
def lift_reference(case: str) -> tuple:
    """Radau from rest at Q0, held, the valve current stepping to iv at T_STEP (two pieces, so
    the step is not smeared)."""
    overrides, iv, pb0 = LIFTS[case]
    law = Hydraulics.of(boom(**overrides)["joints"][0]["actuator"])
    pa, pb, x = held(Q0, pb0)
    opts = {"method": "Radau", "rtol": 1e-10, "atol": [1e-12, 1e-12, 1e-4, 1e-4, 1e-12],
            "dense_output": True}
    before = solve_ivp(law.boom_rhs, (0.0, T_STEP), [Q0, 0.0, pa, pb, x], args=(0.0,), **opts)
    after = solve_ivp(law.boom_rhs, (T_STEP, T_LIFT), before.y[:, -1], args=(iv,), **opts)
    assert before.success and after.success
    return before.sol, after.sol


@pytest.mark.parametrize("dt", list(TOLERANCES), ids=["derived-step", "0.1ms"])
@pytest.mark.parametrize("case", list(LIFTS))
def test_lifting_the_boom_matches_an_independent_integration(case: str, dt: float | None,
                                                             tmp_path: Path) -> None:
    """q, pA and pB of the plant (every millisecond) against Radau (rtol 1e-10) of the rigid
    boom I q̈ = τ_g(q) + F r(q) and the chambers, valve edges and spool of chambers.h written
    here; the spec goes through a YAML file. The boom rises ≥ 0.2 rad, both chambers stay above
    tank after the valve opens and below the relief. Measured: pA 1.3e-4 at the derived step
    (0.5 ms; 5e-4 at 1 ms), 5e-6 at 0.1 ms (RK4 at 0.1 ms, before the exponential step: 2e-5)."""
    overrides, iv, pb0 = LIFTS[case]
    TOLERANCE = TOLERANCES[dt]
    path = tmp_path / "boom.yaml"
    path.write_text(yaml.safe_dump(boom(**overrides)))
    run = ml.simulate(ml.load_spec(path), inputs={"luff": ml.signals.step(iv, t0=T_STEP)},
                      duration=T_LIFT, initial=initial(Q0, pb0), dt=dt, sample_dt=1e-3)
    before, after = lift_reference(case)
    t = run.t
    ref = np.where(t <= T_STEP, before(np.minimum(t, T_STEP)), after(np.maximum(t, T_STEP)))
    q, pa, pb = run.q[:, 0], run["pA"][:, 0], run["pB"][:, 0]
    assert q[0] - q[-1] > 0.2
    opened = t > T_STEP
    assert np.all(pa[opened] > PT) and np.all(pb[opened] > PT)
    assert max(pa.max(), pb.max()) < RELIEF
    for name, sim, exact in (("q", q, ref[0]), ("pA", pa, ref[2]), ("pB", pb, ref[3])):
        error = np.max(np.abs(sim - exact)) / np.ptp(exact)
        assert error < TOLERANCE, f"{name}: {error:.3g} of its range"
    if case == "compensated":  # the compensator holds the meter-in drop throughout
        assert np.all(PS - pa[opened] > LIFTS[case][0]["valve"]["compensator_margin"])
    if case == "brief":  # no leakage: held still until the valve opens
        assert np.max(np.abs(q[t <= T_STEP] - Q0)) < 1e-9


# --- 2. a symmetric double-rod cylinder at mid-stroke is the lumped cylinder --------------------

PS2, M_SLIDE, FV = 8.0e6, 500.0, 1.0e5
HALF_STROKE = 0.2
TAU2, IV2 = 3.0e-4, 0.05
A2 = A_B                                           # double rod: both sides the annulus
V_CHAMBER = DEAD + A2 * HALF_STROKE                # each chamber at mid-stroke
V_EQ = V_CHAMBER / 2.0
K2 = VALVE["nominal_flow"] / math.sqrt(VALVE["nominal_pressure_drop"] / 2.0)
# With tank at 0, the two chambers equal and a symmetric valve, pA + pB = Ps stays (start there):
# Q_A = K x sqrt(Ps - pA) = K x sqrt(Ps/2) sqrt(1 - ΔP/Ps) = -Q_B for x > 0 (for x < 0
# -K|x| sqrt(pA) = ... sqrt(1 + ΔP/Ps)), and d(pA - pB)/dt = 2E/V (Q_A - A v): eq. (4) with
# V_eq = V/2 and the orifice law i_v C sqrt(1 - sign(i_v) ΔP/Ps), C = K sqrt(Ps/2) / i_max
# (x = i_v / i_max at steady state).
C2 = K2 * math.sqrt(PS2 / 2.0) / 1.0


def slide(actuator: dict) -> ml.ManipulatorSpec:
    """A mass sliding along x (gravity across it) with viscous friction, on ``actuator``."""
    return ml.ManipulatorSpec.from_dict({
        "name": "slide", "gravity": [0.0, 0.0, -G],
        "joints": [{"name": "x", "type": "P", "axis": "x", "limits": [-0.19, 0.19],
                    "body": {"mass": M_SLIDE}, "actuator": actuator,
                    "friction": {"model": "hybrid", "viscous": FV}}]})


def test_symmetric_cylinder_at_mid_stroke_is_the_lumped_one() -> None:
    """A double-rod cylinder along a prismatic joint (s = q + 0.7 m, r = 1, mid-stroke at q = 0,
    tank 0, pA = pB = Ps/2) against eq. (4) with A, V_eq = (V_0 + A stroke/2)/2 and
    C = K sqrt(Ps/2)/i_max, the same small valve step: q within 1e-3 and pA - pB within 1 % of
    their peaks, pA + pB within 0.1 % of Ps.

    What differs: the orifices' laminar transition (flow (1 + (p_l/(Ps/2))²)^(-1/4), 1.2e-4 off);
    the volumes, which change by (δ/V)² ~ 1e-3 (the piston moves 6 mm of the 237 mm the chamber's
    oil would fill); and the lag: eq. (4) lags the whole flow Q* = i_v C sqrt(1 - ΔP/Ps), the
    spool only the opening, which adds τ C i_v/(2 Ps) dΔP/dt to the flow, changing the oil's
    capacitance by E τ C i_v / (2 Ps V_eq) = 0.3 % at τ = 0.3 ms (it shrinks with τ). The viscous
    friction (damping ratio ~0.3) keeps the oil spring's ringing, where that adds up, short."""
    cylinder = {"pins": {"parent": [0.0, 0.0, 0.0], "child": [0.7, 0.0, 0.0]},
                "bore": BORE, "rod": ROD, "min_length": 0.5, "stroke": 2.0 * HALF_STROKE,
                "dead_volumes": [DEAD, DEAD], "double_rod": True}
    pinned = slide({"type": "hydraulic", "cylinder": cylinder, "valve": {**VALVE, "tau": TAU2},
                    "supply_pressure": PS2, "tank_pressure": 0.0})
    lumped = slide({"type": "hydraulic", "area": A2, "volume": V_EQ, "valve_gain": C2,
                    "supply_pressure": PS2, "valve_tau": TAU2, "current_limit": 1.0})
    u = ml.signals.step(IV2, t0=0.01)
    two = ml.simulate(pinned, inputs={"x": u}, duration=0.5,
                      initial={"pA": [PS2 / 2.0], "pB": [PS2 / 2.0]})
    one = ml.simulate(lumped, inputs={"x": u}, duration=0.5)
    q, dp = one.q[:, 0], one["dP"][:, 0]
    assert q[-1] > 5e-3 and np.abs(dp).max() > 0.04 * PS2  # it moves, the pressure rings
    assert np.max(np.abs(two.q[:, 0] - q)) < 1e-3 * np.max(np.abs(q))
    assert np.max(np.abs(two["pA"][:, 0] - two["pB"][:, 0] - dp)) < 1e-2 * np.max(np.abs(dp))
    assert np.max(np.abs(two["pA"][:, 0] + two["pB"][:, 0] - PS2)) < 1e-3 * PS2


# --- 3. the relief valves at a stop --------------------------------------------------------------

STOPS = {  # valve wide open into a limit: the chamber that pushes rises to the supply's pressure
    "lifting": (-0.8, 1.0, "pA", -1.0, ml.friction.FrictionMode.AT_LOWER),
    "lowering": (0.0, -1.0, "pB", 0.3, ml.friction.FrictionMode.AT_UPPER),
}


@pytest.mark.parametrize("case", list(STOPS))
def test_relief_caps_the_pressure_at_a_stop(case: str) -> None:
    """With relief_pressure 6 MPa below the 8 MPa supply, driving the boom into its stop: every
    sample of pA and pB ≤ 1.01 p_r and the pushing chamber reaches ≥ 0.99 p_r (the relief acts).
    Without relief the run stays stable and that chamber settles at the supply's pressure
    (never above it: the metering edge closes as the drop vanishes)."""
    q0, iv, chamber, limit, mode = STOPS[case]
    relief = 6.0e6
    runs = {}
    for setting in (relief, None):
        spec = ml.ManipulatorSpec.from_dict(boom(relief_pressure=setting))
        runs[setting] = ml.simulate(spec, inputs={"luff": iv}, duration=1.5, initial=initial(q0))
    run = runs[relief]
    assert run.q[-1, 0] == limit and run["mode"][-1, 0] == mode  # at the stop
    assert max(run["pA"].max(), run["pB"].max()) <= 1.01 * relief
    assert run[chamber][:, 0].max() >= 0.99 * relief
    free = runs[None][chamber][:, 0]
    assert free.max() <= PS * (1.0 + 1e-9)
    assert free[-1] >= 0.999 * PS


# --- 4. the energy of a boom let down -----------------------------------------------------------

def test_energy_balance_of_a_lowered_boom() -> None:
    """The valve opened backwards (P->B, A->T) lets the boom down under its load. From the run's
    samples (every 1 ms step, trapezoids): the pump's work W = ∫ (Ps Q_P - Pt Q_T) dt, the
    orifices' dissipation D = ∫ Σ_edges Q Δp dt (the flows from the sampled states by the edge
    law written here), the oil's compression energy ∫ Σ p V/E dp over the sampled pressures, and
    the rigid boom's ΔE = Δ(½ I q̇² + potential). The oil delivered to the chambers,
    pA Q_A + pB Q_B = W - D, goes into the piston, (pA A_A - pB A_B) ds/dt = F r q̇ = dE/dt,
    and into compressing the oil, Σ p V/E dp/dt: W - D - ΔE - E_oil = 0 up to the sampling
    error, ~3e-7 D here; 1e-4 D allows it and still sees a 2 % error in the oil's stiffness.
    The pressures stay within (Pt, p_r), so neither the anti-cavitation nor the relief valves
    (which would take or give oil outside the edges) act."""
    q0 = -0.6
    run = ml.simulate(ml.ManipulatorSpec.from_dict(boom()), duration=1.5, dt=1e-3,
                      sample_dt=1e-3, inputs={"luff": ml.signals.step(-0.5, t0=0.05)},
                      initial=initial(q0))
    law = Hydraulics.of(boom()["joints"][0]["actuator"])
    t, q, v = run.t, run.q[:, 0], run.qd[:, 0]
    pa, pb, x = run["pA"][:, 0], run["pB"][:, 0], run["spool"][:, 0]
    assert q[-1] - q0 > 0.2  # it went down
    assert np.all(pa[t > 0.05] > PT) and np.all(pb[t > 0.05] > PT)
    assert max(pa.max(), pb.max()) < RELIEF
    pa_in, b_out, pb_in, a_out = law.edges(x, pa, pb)
    work = trapezoid(PS * (pa_in + pb_in) - PT * (b_out + a_out), t)
    loss = trapezoid(pa_in * (PS - pa) + b_out * (pb - PT) + pb_in * (PS - pb)
                     + a_out * (pa - PT), t)
    va, vb = volumes(np.array([length(angle) for angle in q]))

    def compression(p: np.ndarray, vol: np.ndarray) -> float:
        pv = p * vol / law.bulk_modulus
        return float(np.sum(0.5 * (pv[1:] + pv[:-1]) * np.diff(p)))

    oil = compression(pa, va) + compression(pb, vb)
    mechanical = 0.5 * INERTIA * (v[-1] ** 2 - v[0] ** 2) + potential(q[-1]) - potential(q0)
    assert loss > 0.0 and mechanical < 0.0
    assert abs(work - loss - mechanical - oil) < 1e-4 * loss, (work, loss, mechanical, oil)


@pytest.mark.parametrize("arm", ["patu655", "excavator"])
def test_steady_states_hold_the_force_with_steady_chambers(arm: str) -> None:
    """At random poses, speeds and forces within what the cylinder holds, a steady state found
    exerts the force (to 1e-9), opens the spool at most fully, and its chambers do not change:
    each chamber's flow balance is off by at most 0.1 % of the valve's nominal flow (the
    documented mismatch of creeping speeds; exact elsewhere), or the chamber sits at tank
    pressure falling (its anti-cavitation valve holds it there); most cases are found."""
    spec = ml.builtin_spec(arm)
    rng = np.random.default_rng(7)
    found = 0
    for joint in spec.joints:
        actuator = model_of(joint)
        if not isinstance(actuator, PinnedCylinder):
            continue
        p = actuator.params
        for _ in range(40):
            q = float(rng.uniform(*joint.limits))
            low, high = actuator.holding_range(q)
            force = float(rng.uniform(0.8 * low, 0.8 * high))
            v = float(rng.choice([0.0, 1e-4, -1e-3, 0.05, -0.05, 0.2]))
            st = actuator.steady(force, q, v)
            if not np.isfinite(st.u):
                continue
            found += 1
            assert abs(st.u) <= p.valve.current_limit
            assert actuator.force(st.x, st.u, q, v) == pytest.approx(force, rel=1e-9, abs=1e-6)
            rates = actuator.derivatives(st.x, st.u, q, v)
            volumes = chambers.flows(actuator.law, st.x, float(actuator.geometry.length(q)))[2:]
            for k in (0, 1):
                unbalanced = abs(rates[k]) * volumes[k] / p.bulk_modulus  # m³/s
                at_tank = st.x[k] == pytest.approx(p.tank_pressure, abs=1.0)
                assert unbalanced <= 1e-3 * p.valve.nominal_flow or (at_tank and rates[k] < 0.0)
            assert abs(rates[2]) <= 1e-9
    assert found >= 60


def _with_supply(max_flow: float | None) -> ml.ManipulatorSpec:
    data = ml.builtin_spec("patu655").to_dict()
    if max_flow is not None:
        data["supply"] = {"pressure": 8.0e6, "max_flow": max_flow}
    return ml.ManipulatorSpec.from_dict(data)


def _two_cylinders(spec: ml.ManipulatorSpec, tilt: float) -> ml.Run:
    return ml.simulate(spec, duration=1.5, inputs={"lift": 1.0, "tilt": tilt},
                       initial={"q": [0.0, -0.4, 1.0], "dP": "gravity"}, progress=False)


@pytest.mark.parametrize("tilt", [1.0, -1.0])
def test_a_shared_pump_shares_its_flow_between_cylinders_moving_together(tilt: float) -> None:
    """PATU 655's lift and tilt valves both wide open, pushing their loads, on one pump of
    24 L/min (less than the two valves pass): the oil entering the two filling chambers, A_A or
    A_B times the piston speed from the recorded strokes, adds up to the pump's flow (to 1 %,
    the chambers' compression aside), and both cylinders move slower than with a supply each.
    A pump larger than the valves' flows changes nothing (to 1e-12)."""
    pump = 4.0e-4
    alone, shared = _two_cylinders(_with_supply(None), tilt), _two_cylinders(_with_supply(pump), tilt)
    t = shared.t
    k0, k1 = np.searchsorted(t, [0.5, 1.4])
    speed = (shared["stroke"][k1] - shared["stroke"][k0]) / (t[k1] - t[k0])
    speed_alone = (alone["stroke"][k1] - alone["stroke"][k0]) / (t[k1] - t[k0])
    cap, rod = np.pi / 4 * 0.1**2, np.pi / 4 * (0.1**2 - 0.056**2)
    inflow = [cap * v if v > 0 else -rod * v for v in speed[1:]]
    assert sum(inflow) == pytest.approx(pump, rel=1e-2)
    assert np.all(np.abs(speed[1:]) < 0.9 * np.abs(speed_alone[1:]))
    roomy = _two_cylinders(_with_supply(1.0), tilt)
    assert roomy.q == pytest.approx(alone.q, abs=1e-12)
    assert roomy["pA"] == pytest.approx(alone["pA"], rel=1e-12, nan_ok=True)


@pytest.mark.parametrize(("change", "words"), [
    ({"pressure": 9.0e6}, "joint lift's actuator.supply_pressure 8e+06 Pa differs"),
    ({"max_flow": -1.0}, "max_flow"),
])
def test_a_shared_supply_that_does_not_fit_is_one_line(change: dict, words: str) -> None:
    data = ml.builtin_spec("patu655").to_dict()
    data["supply"] = {"pressure": 8.0e6, "max_flow": 4e-4, **change}
    with pytest.raises(ml.SpecError) as info:
        ml.ManipulatorSpec.from_dict(data)
    assert words in str(info.value) and "supply" in str(info.value)
    lumped = ml.builtin_spec("crane3").to_dict()
    lumped["supply"] = {"pressure": 8.0e6, "max_flow": 4e-4}
    with pytest.raises(ml.SpecError, match="no joint has a pinned cylinder"):
        ml.ManipulatorSpec.from_dict(lumped)


def test_the_valve_flows_of_many_states_are_those_of_each() -> None:
    """The batched valve law the steady solve's pressure grid uses gives, state by state, the
    flows of the one-state call (both directions of the spool, pressures around tank and
    supply)."""
    actuator = model_of(ml.builtin_spec("patu655").joint("lift"))
    p = actuator.params
    rng = np.random.default_rng(11)
    states = np.column_stack([rng.uniform(-0.1, 1.1, 200) * p.supply_pressure,
                              rng.uniform(-0.1, 1.1, 200) * p.supply_pressure,
                              rng.uniform(-1.0, 1.0, 200)])
    states[:5, 2] = [0.0, -0.0, 1.0, -1.0, 1e-12]
    many = chambers.valve_flows(actuator.law, states)
    s = float(actuator.geometry.length(0.0))
    np.testing.assert_array_equal(many, [chambers.flows(actuator.law, x, s)[:2] for x in states])


# --- 1b. a compensated section on a load-sensing pump lifting the boom, against Radau -----------

LS_MARGIN, LS_COMPENSATOR, LS_CURRENT = 15.0e5, 12.0e5, 1.0


@dataclasses.dataclass(frozen=True)
class LoadSensed(Hydraulics):
    """The boom's section on its own load-sensing pump: the pump's pressure is the chamber the
    open meter-in edge feeds plus the pump's margin, at most its cut-off PS (tank plus the
    margin with the spool closed); the section's compensator holds its meter-in drop."""

    pump_margin: float = LS_MARGIN

    def supply(self, x: float, pa: float, pb: float) -> float:
        """The pump's pressure: the sensed chamber plus its margin, at most PS."""
        sensed = pa if x > 0.0 else (pb if x < 0.0 else PT)
        return min(PS, sensed + self.pump_margin)


@functools.cache
def ls_reference():
    valve = {**VALVE, "compensator_margin": LS_COMPENSATOR}
    plain = Hydraulics.of(boom(valve=valve)["joints"][0]["actuator"])
    law = LoadSensed(**dataclasses.asdict(plain))
    pa, pb, x = held(Q0)
    opts = {"method": "Radau", "rtol": 1e-10, "atol": [1e-12, 1e-12, 1e-4, 1e-4, 1e-12],
            "dense_output": True}
    before = solve_ivp(law.boom_rhs, (0.0, T_STEP), [Q0, 0.0, pa, pb, x], args=(0.0,), **opts)
    after = solve_ivp(law.boom_rhs, (T_STEP, T_LIFT), before.y[:, -1], args=(LS_CURRENT,),
                      **opts)
    assert before.success and after.success
    return before.sol, after.sol


@pytest.mark.parametrize("dt", list(TOLERANCES), ids=["derived-step", "0.1ms"])
def test_a_compensated_section_on_a_load_sensing_pump_lifting_the_boom_matches_radau(dt):
    """The boom lifted through a section compensated at 12 bar on its own 15 bar load-sensing
    pump (its cut-off the supply pressure): q, pA and pB against Radau of the equations written
    here (:class:`LoadSensed`), within the tolerances of the lift on a constant supply. Measured:
    pA and pB 2.1e-4 of their ranges at the derived step (0.5 ms), 8.4e-6 at 0.1 ms."""
    data = boom(valve={**VALVE, "compensator_margin": LS_COMPENSATOR})
    data["supply"] = {"pressure": PS, "max_flow": 1.0, "ls_margin": LS_MARGIN}
    run = ml.simulate(ml.ManipulatorSpec.from_dict(data),
                      inputs={"luff": ml.signals.step(LS_CURRENT, t0=T_STEP)}, duration=T_LIFT,
                      initial=initial(Q0), dt=dt, sample_dt=1e-3)
    before, after = ls_reference()
    t = run.t
    ref = np.where(t <= T_STEP, before(np.minimum(t, T_STEP)), after(np.maximum(t, T_STEP)))
    q, pa, pb = run.q[:, 0], run["pA"][:, 0], run["pB"][:, 0]
    assert q[0] - q[-1] > 0.2
    for name, sim, exact in (("q", q, ref[0]), ("pA", pa, ref[2]), ("pB", pb, ref[3])):
        error = np.max(np.abs(sim - exact)) / np.ptp(exact)
        assert error < TOLERANCES[dt], f"{name}: {error:.3g} of its range"


LS_RESPONSE = 0.03
"""s: the pump pressure's response time in the test below (a swash plate's regulator)."""


@dataclasses.dataclass(frozen=True)
class LaggingPump(LoadSensed):
    """The boom's compensated section on a load-sensing pump whose pressure p answers with a
    first-order lag: dp/dt = (min(PS, sensed + margin) - p) / tau_p, the section's meter-in edge
    seeing p (the state vector gains p at its end)."""

    pump_tau: float = LS_RESPONSE

    def pump_rhs(self, t: float, z: np.ndarray, iv: float) -> list[float]:
        """(q, q̇, pA, pB, x, p)': the boom's at the pump's pressure p, and p's lag towards
        the quasi-static pump's (:meth:`LoadSensed.supply`)."""
        _, _, pa, pb, x, p = z
        target = self.supply(x, pa, pb)
        return [*self.boom_rhs(t, z[:5], iv, ps=p), (target - p) / self.pump_tau]


@pytest.mark.parametrize("dt", list(TOLERANCES), ids=["derived-step", "0.1ms"])
def test_a_load_sensing_pump_with_a_response_time_lifting_the_boom_matches_lsoda(dt):
    """The same lift with the pump's pressure answering in 30 ms: it stands by at tank plus its
    margin, so the lift starts only as the pump rises past the cap side's pressure; q, pA, pB
    against LSODA of :class:`LaggingPump` (its pump state exact: the plant relaxes it towards
    the target over each step). Measured: pA 1.4e-4 of its range at the derived step (0.5 ms),
    5.7e-6 at 0.1 ms, second order."""
    valve = {**VALVE, "compensator_margin": LS_COMPENSATOR}
    plain = Hydraulics.of(boom(valve=valve)["joints"][0]["actuator"])
    law = LaggingPump(**dataclasses.asdict(plain))
    pa0, pb0, x0 = held(Q0)
    # LSODA: as the spool leaves 0 the load-sense pressure jumps from tank to the cap side, a
    # jump in the pump's rate that Radau's step control does not pass
    opts = {"method": "LSODA", "rtol": 1e-10, "atol": [1e-12, 1e-12, 1e-4, 1e-4, 1e-12, 1e-4],
            "dense_output": True}
    z0 = [Q0, 0.0, pa0, pb0, x0, PT + LS_MARGIN]
    before = solve_ivp(law.pump_rhs, (0.0, T_STEP), z0, args=(0.0,), **opts)
    after = solve_ivp(law.pump_rhs, (T_STEP, T_LIFT), before.y[:, -1], args=(LS_CURRENT,),
                      **opts)
    data = boom(valve=valve)
    data["supply"] = {"pressure": PS, "max_flow": 1.0, "ls_margin": LS_MARGIN,
                      "response": LS_RESPONSE}
    run = ml.simulate(ml.ManipulatorSpec.from_dict(data),
                      inputs={"luff": ml.signals.step(LS_CURRENT, t0=T_STEP)}, duration=T_LIFT,
                      initial=initial(Q0), dt=dt, sample_dt=1e-3)
    t = run.t
    ref = np.where(t <= T_STEP, before.sol(np.minimum(t, T_STEP)),
                   after.sol(np.maximum(t, T_STEP)))
    q, pa, pb = run.q[:, 0], run["pA"][:, 0], run["pB"][:, 0]
    assert q[0] - q[-1] > 0.2
    for name, sim, exact in (("q", q, ref[0]), ("pA", pa, ref[2]), ("pB", pb, ref[3])):
        error = np.max(np.abs(sim - exact)) / np.ptp(exact)
        assert error < TOLERANCES[dt], f"{name}: {error:.3g} of its range"
