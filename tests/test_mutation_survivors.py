"""Tests written for mutants that survived ``make mutants`` (tests/mutants/run.py) and were not
equivalent: each names the change it kills (docs/about/development.md, "Mutation testing")."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

import maniplab as ml
from maniplab.actuators.hydraulic import PinnedCylinder, chambers
from maniplab.control.metrics import _pressures, format_table
from maniplab.control.move import run_move
from maniplab.control.pid import PID
from maniplab.control.trajectory import Path as MovePath
from maniplab.control.trajectory import Pose, segment_placement
from maniplab.errors import SpecError
from maniplab.fmu.variables import variables
from maniplab.friction import steady_force
from maniplab.identification.parameters import parse_parameters
from maniplab.loadchart import Statics, load_chart
from maniplab.sim.plant import Plant
from maniplab.spec import model_of

ARMS = Path(__file__).parent / "arms"


def test_via_points_without_a_dwell_go_straight_on() -> None:
    """Kills ``dwell: float = 0.0`` -> ``1`` in ``Path.via_points`` (trajectory.py): no Hold
    segment and no added time unless a dwell is asked for."""
    poses = [Pose([0.0, 0, 0]), Pose([1.0, 0, 0]), Pose([1.0, 1.0, 0])]
    path = MovePath.via_points(poses, [2.0, 3.0])
    assert path.duration == pytest.approx(5.0)
    assert [type(s).__name__ for s in path.segments] == ["MinJerkMove", "MinJerkMove"]


def test_peak_pressures_of_an_arm_with_electric_joints_and_an_unloaded_cylinder() -> None:
    """Kills, in ``_pressures`` (control/metrics.py), ``if mine and not peak <= best`` -> ``or``
    (a joint without pressures, an electric one, then crashes the table) and ``v[j] >= 0.0`` ->
    ``> 0.0`` (a cylinder that never carries a load, crane3's slew at rest: its peak is 0 MPa,
    not missing)."""
    run = ml.simulate(ml.load_spec(ARMS / "electrohydraulic.yaml"), duration=0.02,
                      initial={"dP": "gravity"}, progress=False)
    table = _pressures(run)
    electric = [j.name for j in run.spec.joints if j.actuator.type != "hydraulic"]
    assert electric and all(table["joints"][j]["pressure"] == "" for j in electric)
    assert np.isfinite(table["peak_pressure_MPa"]) and table["peak_pressure_joint"]
    crane = ml.simulate(ml.builtin_spec("crane3"), duration=0.02, initial={"dP": "gravity"},
                        progress=False)
    slew = _pressures(crane)["joints"]["slew"]
    assert slew["pressure"] == "dP" and slew["peak_pressure_MPa"] == 0.0


def test_the_fmu_states_a_bristle_deflection_in_the_joints_position_unit() -> None:
    """Kills ``_motion_units(plant, j)[0]`` -> ``[1]`` in ``_state_unit`` (fmu/variables.py):
    LuGre's bristle deflection z of a revolute joint is in rad, not rad/s."""
    plant = Plant(ml.load_spec(ARMS / "electrohydraulic.yaml"))
    units = {v.name: v.unit for v in variables(plant, [])}
    bristles = [name for name in units if name.startswith("z.")]
    assert bristles and all(units[name] == "rad" for name in bristles), units


def _lift() -> PinnedCylinder:
    spec = ml.builtin_spec("patu655")
    actuator = model_of(spec.joint("lift"))
    assert isinstance(actuator, PinnedCylinder)
    return actuator


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_holding_pressures_exert_the_force_either_way(sign: float) -> None:
    """Kills ``(tank * c.cap_area - f) / c.rod_area`` -> ``(tank * c.cap_area) / c.rod_area`` in
    ``PinnedCylinder.holding`` (pinned.py): a load the cylinder holds by pulling puts the rod
    side above tank, by pA A_A - pB A_B = F (F = τ / r), the cap side at tank."""
    cylinder, q = _lift(), 0.0
    low, high = cylinder.holding_range(q)
    torque = 0.5 * (high if sign > 0 else low)
    pa, pb, spool = cylinder.holding(torque, q)
    c, tank = cylinder.params.cylinder, cylinder.params.tank_pressure
    force = torque / float(cylinder.geometry.arm(q))
    assert pa * c.cap_area - pb * c.rod_area == pytest.approx(force, rel=1e-12)
    assert min(pa, pb) == tank and spool == 0.0


def test_a_steady_speed_beyond_the_valves_reach_asks_for_an_infinite_current() -> None:
    """Kills ``abs(x[2]) <= 1.0`` -> ``<= 2.0`` in ``PinnedCylinder.steady`` (pinned.py): over
    speeds up to three times what the open valve passes, every steady current is within the
    current limit or infinite (no opening within ±1 does it), and both happen."""
    cylinder, q = _lift(), -0.2
    high = cylinder.holding_range(q)[1]
    limit = cylinder.params.valve.current_limit
    currents = [cylinder.steady(0.3 * high, q, v).u
                for v in np.linspace(-3.0, 3.0, 61) * cylinder.top_speed]
    assert all(abs(u) <= limit or np.isinf(u) for u in currents), currents
    assert any(np.isinf(u) for u in currents) and any(0.5 * limit < abs(u) <= limit
                                                      for u in currents)


def test_a_load_chart_of_one_joint_takes_the_whole_pose_budget() -> None:
    """Kills ``active = max(1, ...)`` -> ``max(2, ...)`` in ``load_chart`` (loadchart.py): with
    one joint that moves, the grid has ``max_poses`` points along it, not their square root."""
    from test_loadchart import BOOM

    chart = load_chart(ml.ManipulatorSpec.from_dict(BOOM), max_poses=40)
    assert len(chart.q) == 40


def test_a_small_pose_budget_keeps_two_points_per_joint() -> None:
    """Kills ``points = max(2, ...)`` -> ``max(4, ...)`` in ``load_chart`` (loadchart.py): a
    budget of 8 poses over crane3's two joints that gravity loads (the slew turns about the
    vertical, idle) is a grid of 2 × 2, not 4 × 4. Also kills ``spec.n - len(idle)`` -> ``+``
    (100 poses over crane3's two loaded joints: 10 × 10, not 3 × 3) and dropping the ``+ 1e-9``
    of the root (1000 ** (1/3) is 9.999999999999998: the excavator's three loaded joints get
    10 points each, not 9)."""
    assert len(load_chart("crane3", max_poses=8).q) == 4
    assert len(load_chart("crane3", max_poses=100).q) == 100
    assert len(load_chart("excavator", max_poses=1000).q) == 1000


def test_lugre_steady_force_at_rest_is_zero() -> None:
    """Kills ``g * np.sign(v)`` -> ``g / np.sign(v)`` in ``steady_force`` (friction/lugre.py):
    the same for every sliding speed, but at rest the Stribeck curve passes through 0."""
    friction = ml.Friction(model="lugre", coulomb=1.0, static=0.5, stribeck_velocity=1e-3,
                           viscous=0.4)
    with np.errstate(divide="ignore", invalid="ignore"):
        forces = steady_force(friction, np.array([-0.1, 0.0, 0.1]))
    assert forces[1] == 0.0 and forces[2] == -forces[0] > 1.0


def test_segment_placement_without_a_dwell_and_with_its_default_durations() -> None:
    """Kills, in ``segment_placement`` (trajectory.py), ``if dwell > 0.0`` -> ``>=`` (zero-length
    holds) and the default ``durations=(2.0, 4.0, 2.0)`` -> ``(2.0, 4.0, 4.0)`` or the like:
    pick, rotate and push take 2 + 4 + 2 s, with no dwell between them when none is asked."""
    path = segment_placement(Pose([0.4, -3.2, 0.0]), dwell=0.0)
    assert path.names == ("pick", "rotate", "push")
    assert [s.duration for s in path.segments] == pytest.approx([2.0, 4.0, 2.0])


def test_the_pid_baseline_moves_crane3_out_and_back() -> None:
    """Kills ``limits=(-vmax, vmax)`` -> ``(vmax, vmax)`` for the PID-only baseline's joint
    loop (control/cascade.py; the limits bind on hydraulic joints, whose top speed is finite):
    crane3's baseline move out ends within 5 mm of its target 4 s after the move (the baseline
    converges slowly: each joint's integral starts when the path stops), and so does the move
    back. Also
    kills ``"-" * (w + 2)`` -> ``(w - 2)`` in ``format_table`` (control/metrics.py)."""
    spec = ml.builtin_spec("crane3")
    model = ml.AnalyticModel(spec)
    for start, goal in (([0.0, -0.3, 0.5], [0.3, -0.5, 0.8]),
                        ([0.3, -0.5, 0.8], [0.0, -0.3, 0.5])):
        target = model.fk(np.array(goal))[:3, 3].tolist()
        result = run_move(spec, target, start=start, duration=3.0, mode="pid", settle=4.0)
        # measured: 2.0 and 3.1 mm; 12 m with the mutant
        assert result.metrics.final_error_mm < 5.0, (goal, result.metrics.final_error_mm)
    lines = format_table([result.metrics]).splitlines()  # a Markdown table, its columns aligned
    assert len(lines) == 3 and len({len(line) for line in lines}) == 1, lines


def test_a_load_chart_charts_a_joint_without_limits_all_round() -> None:
    """Kills ``joint.limits or (-math.pi, math.pi)`` -> ``(math.pi, math.pi)`` in ``load_chart``
    (loadchart.py): a boom without limits is charted over a whole turn."""
    import copy

    from test_loadchart import BOOM

    boom = copy.deepcopy(BOOM)
    del boom["joints"][0]["limits"]
    q = load_chart(ml.ManipulatorSpec.from_dict(boom), points=5).q[:, 0]
    assert q.min() == pytest.approx(-np.pi) and np.ptp(q) > 1.5 * np.pi


def test_the_pinned_law_takes_each_chambers_dead_volume_and_no_relief_when_none() -> None:
    """Kills, in ``chambers_law`` (actuators/hydraulic/chambers.py), ``dead_volumes[0]`` ->
    ``[1]`` (every built-in has equal ones) and ``relief_pressure or 0.0`` -> ``or 1`` (a
    relief at 1 Pa), and ``np.empty(3)`` -> ``np.empty(6)`` in ``rates``. With the valve closed and no leakage, dpA/dt = -E A_A ṡ / (V_A0 + A_A y)
    and the force of the model is pA A_A - pB A_B at pressures above every relief setting."""
    data = ml.builtin_spec("patu655").to_dict()
    lift = next(j for j in data["joints"] if j["name"] == "lift")
    lift["actuator"]["cylinder"]["dead_volumes"] = [1.0e-4, 6.0e-4]
    lift["actuator"]["relief_pressure"] = None
    lift["actuator"]["leakage"] = 0.0
    spec = ml.ManipulatorSpec.from_dict(data)
    cylinder = model_of(spec.joint("lift"))
    assert isinstance(cylinder, PinnedCylinder)
    p = cylinder.params
    c, q, sdot = p.cylinder, -0.3, 0.01
    s = float(cylinder.geometry.length(q))
    rates = chambers.rates(cylinder.law, np.array([5e6, 1e6, 0.0]), 0.0, s, sdot)
    assert rates.shape == (3,)  # (dpA/dt, dpB/dt, dx/dt), as documented
    rate_a = rates[0]
    volume_a = 1.0e-4 + c.cap_area * (s - c.min_length)
    assert rate_a == pytest.approx(-p.bulk_modulus * c.cap_area * sdot / volume_a, rel=1e-12)
    x = np.array([2.0e7, 1.0e6, 0.0])  # beyond any relief setting: none clamps it
    r = float(cylinder.geometry.arm(q))
    force = cylinder.force(x, 0.0, q, 0.0)
    assert force == pytest.approx((2.0e7 * c.cap_area - 1.0e6 * c.rod_area) * r, rel=1e-12)


def test_a_lumped_cylinders_steady_flow_is_the_pistons_and_the_leakage() -> None:
    """Kills ``float(out[1])`` -> ``float(out[2])`` in ``cylinder_steady`` (valve.py): the
    steady state's flow Q = A v + Le ΔP (no relief flow below the relief), not the current."""
    cylinder = model_of(ml.builtin_spec("crane3").joint("luff"))
    p = cylinder.params
    steady = cylinder.steady(2000.0, -0.3, 0.05)
    dP, flow = steady.x
    assert dP == pytest.approx(2000.0 / p.area, rel=1e-12)
    assert flow == pytest.approx(p.area * 0.05 + p.leakage * dP, rel=1e-9)
    assert abs(steady.u) < p.current_limit


def test_limits_at_the_very_ends_of_the_stroke_are_accepted() -> None:
    """Kills ``s.min() < shortest - slack`` -> ``shortest + slack`` in the stroke check
    (geometry.py): limits that need the cylinder exactly from its shortest to its longest (the
    range the stroke allows, computed) are accepted, as the check's tolerance intends."""
    spec = ml.builtin_spec("patu655")
    cylinder = model_of(spec.joint("lift"))
    assert isinstance(cylinder, PinnedCylinder)
    c = cylinder.params.cylinder
    low, high = cylinder.geometry.span(c.min_length, c.max_length, 0.0)
    data = spec.to_dict()
    lift = next(j for j in data["joints"] if j["name"] == "lift")
    lift["limits"] = [float(low), float(high)]
    stretched = ml.ManipulatorSpec.from_dict(data)
    assert stretched.joint("lift").limits == (low, high)


def test_the_tracking_time_follows_astrom_and_hagglunds_rule_for_a_small_kd() -> None:
    """Kills ``self.kd > 0.0`` -> ``> 1`` in ``PID._tracking_time`` (control/pid.py): with a
    derivative, however small its gain, Tt = sqrt(Kd/Ki) (module docstring), not Kp/Ki; the
    anti-windup then bleeds the integrator by (u - v)/Tt per second."""
    pid = PID(3.0, 2.0, 0.5, dt=0.01, limits=(-1.0, 1.0))
    assert pid.tracking_time == pytest.approx([0.5])
    u = pid.update([1.0])  # v = 3 (no derivative kick on the first sample), u = 1
    assert u == pytest.approx([1.0])
    assert pid.integral == pytest.approx(0.01 * (2.0 * 1.0 + (1.0 - 3.0) / 0.5))
    assert PID(3.0, 2.0, dt=0.01).tracking_time == pytest.approx([1.5])  # no derivative: Kp/Ki


def test_a_parameter_by_joint_index_and_one_past_the_last_joint() -> None:
    """Kills ``index < spec.n`` -> ``<=`` in ``_by_name`` (identification/parameters.py): a
    joint named by its index resolves to its name, and the index one past the last joint is a
    one-line SpecError, not an IndexError."""
    spec = ml.builtin_spec("crane3")
    (parameter,) = parse_parameters(["joints.1.friction.coulomb"], spec)
    assert parameter.path == "joints.luff.friction.coulomb"
    with pytest.raises(SpecError, match="joints.3.friction.coulomb"):
        parse_parameters(["joints.3.friction.coulomb"], spec)


def test_a_steady_retraction_under_a_pull_near_the_supply_pressure() -> None:
    """Kills ``(f + Ps * A_B) / A_A`` -> ``(f + Ps / A_B) / A_A`` in ``SteadyFlows._grid``
    (chamber_steady.py): PATU 655's lift holding a pull that takes the rod side to 0.1 MPa below
    the supply with the cap side at tank, retracting at 0.01 rad/s. P->B and A->T then both
    work across small drops, and the cap side settles some 47 kPa above tank. The scan for pA
    up to the pA at which pB reaches Ps finds it; one up to Ps takes steps of 123 kPa, and its
    first (from tank, where the A edge passes nothing) is dropped: no steady state, an infinite
    current. Here the flow balances of chambers.h, solved the other way round (the opening from
    B's, pA a root of A's), give the steady state."""
    cylinder, q, v = _lift(), -0.4, 0.01
    p, c = cylinder.params, cylinder.params.cylinder
    aa, ab, ps, pt, le = c.cap_area, c.rod_area, p.supply_pressure, p.tank_pressure, p.leakage
    edge = 0.5 * p.valve.nominal_pressure_drop  # rated across two edges
    ka = p.valve.nominal_flow / math.sqrt(edge)
    kb = p.valve.flow_ratio * ka
    laminar = 0.05 * edge

    def g(dp: float) -> float:  # the orifice's root, laminar below the transition
        return dp / (dp * dp + laminar * laminar) ** 0.25

    r = float(cylinder.geometry.arm(q))
    sdot = r * v  # < 0: retracting (x < 0: P->B feeds B, A->T drains A)
    pull = pt * aa - (ps - 1e5) * ab  # pA A_A - pB A_B, N

    def pressures_and_opening(pa: float) -> tuple[float, float]:
        pb = (pa * aa - pull) / ab
        need_b = -ab * sdot - le * (pa - pb)  # > 0: into B
        return pb, -need_b / (kb * g(ps - pb))  # K_B |x| g(Ps - pB) = need_b

    def a_balance(pa: float) -> float:  # what A gets through A->T minus what it needs
        pb, x = pressures_and_opening(pa)
        return -ka * -x * g(pa - pt) - (aa * sdot + le * (pa - pb))

    top = (pull + ps * ab) / aa  # pB = Ps: B's edge passes nothing
    pa = brentq(a_balance, pt, top - 1.0, xtol=1e-6, rtol=1e-14)
    pb, x = pressures_and_opening(pa)
    assert sdot < 0.0 and -1.0 < x < 0.0 and 1e4 < pa - pt < 1e5 and pb < ps
    steady = cylinder.steady(pull * r, q, v)
    assert steady.x == pytest.approx([pa, pb, x], rel=1e-6)
    assert steady.u == pytest.approx(x * p.valve.current_limit, rel=1e-6)


GANTRY = {  # slides that move the payload through the base's vertical axis
    "name": "gantry",
    "joints": [{"name": "travel", "type": "P", "axis": "x", "limits": [-3.0, 5.0],
                "body": {"mass": 3000.0}, "actuator": {"type": "torque", "limit": 1e5}},
               {"name": "traverse", "type": "P", "axis": "y", "limits": [-5.0, 3.0],
                "body": {"mass": 1200.0}, "actuator": {"type": "torque", "limit": 1e5}},
               {"name": "hoist", "type": "P", "axis": "z", "limits": [-3.0, 0.0],
                "body": {"mass": 500.0}, "actuator": {"type": "torque", "limit": 1e5}}],
    "end_effector": {"mass": 2000.0, "offset": [0.0, 0.0, -0.5]},
}


def test_a_slide_through_the_base_axis_is_not_idle() -> None:
    """Kills ``np.linspace(low, high, 5)[1:-1]`` -> ``[1:-2]`` and -> ``[2:-1]`` in
    ``Statics.idle_joints`` (loadchart.py): a gantry's horizontal slides carry no load, and the
    payload's height does not depend on them, but they move it towards and away from the base's
    vertical axis: reach = sqrt(x² + y²). The travel's interior values -1, 1, 3 m give reaches
    |x| = 1, 1, 3 (the traverse's -3, -1, 1 m: 3, 1, 1), so a check of only the first two
    (only the last two) calls the travel (the traverse) idle and charts it at one value."""
    spec = ml.ManipulatorSpec.from_dict(GANTRY)
    assert Statics(spec).idle_joints() == frozenset()
    chart = load_chart(spec, points=3)
    x, y = chart.q[:, 0], chart.q[:, 1]
    assert len(chart.q) == 27
    assert sorted(set(x)) == pytest.approx([-1.0, 1.0, 3.0])
    assert sorted(set(y)) == pytest.approx([-3.0, -1.0, 1.0])
    np.testing.assert_allclose(chart.reach, np.hypot(x, y), atol=1e-12)
