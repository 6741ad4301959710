"""The energy of a run (``maniplab.sim.energy``, ``maniplab energy``): the pinned cylinders'
energy terms against Radau of the documented equations with their powers integrated alongside,
the balance on random runs of every arm with a pinned cylinder, the piston work against the
mechanics' own, a fixed pump's relief in closed form, and the command."""

from __future__ import annotations

import dataclasses
import functools
import glob
import json
import math
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp, trapezoid
from test_cylinder_physics import (
    A_A,
    A_B,
    LS_COMPENSATOR,
    LS_CURRENT,
    PS,
    PT,
    Q0,
    T_LIFT,
    T_STEP,
    VALVE,
    Hydraulics,
    LoadSensed,
    arm,
    boom,
    held,
    initial,
)

import maniplab as ml
from maniplab.sim.energy import LOSSES, TERMS, energy_report

ROOT = __file__.rsplit("/tests/", 1)[0]


def _has_pinned_cylinder(arm_name: str) -> bool:
    return any(getattr(j.actuator, "cylinder", None) for j in ml.resolve_spec(arm_name).joints)


PINNED_ARMS = [a for a in ["patu655", "excavator", "erector_pinned", "crane3", *sorted(
    glob.glob(f"{ROOT}/tests/arms/**/*.yaml", recursive=True))] if _has_pinned_cylinder(a)]


# --- 1. a compensated lift on a load-sensing pump, against Radau -----------------------------

def _seen(law: LoadSensed, dp: float) -> float:
    """The drop a compensated meter-in orifice sees: the smooth minimum of dp and the margin."""
    over = dp - law.margin
    return 0.5 * (dp + law.margin - math.sqrt(over * over + law.laminar**2))


def _energy_rhs(law: LoadSensed, t: float, z: np.ndarray, iv: float) -> list[float]:
    """The boom's (q, q̇, pA, pB, x)' and the powers of pump, meter-in, compensator, meter-out
    and piston work (W), written from the hydraulics page's definitions."""
    q, v, pa, pb, x = z[:5]
    ps = law.supply(x, pa, pb)
    pa_in, b_out, pb_in, a_out = law.edges(x, pa, pb, ps)
    seen_a, seen_b = _seen(law, ps - pa), _seen(law, ps - pb)
    return [*law.boom_rhs(t, z[:5], iv, ps),
            ps * (pa_in + pb_in),
            seen_a * pa_in + seen_b * pb_in,
            (ps - pa - seen_a) * pa_in + (ps - pb - seen_b) * pb_in,
            (pb - PT) * b_out + (pa - PT) * a_out,
            (pa * A_A - pb * A_B) * arm(q) * v]


@functools.cache
def _reference() -> np.ndarray:
    """The energies (pump, meter-in, compensator, meter-out, work) at T_LIFT, J."""
    valve = {**VALVE, "compensator_margin": LS_COMPENSATOR}
    plain = Hydraulics.of(boom(valve=valve)["joints"][0]["actuator"])
    law = LoadSensed(**dataclasses.asdict(plain))
    rhs = functools.partial(_energy_rhs, law)
    opts = {"method": "Radau", "rtol": 1e-10,
            "atol": [1e-12, 1e-12, 1e-4, 1e-4, 1e-12, *[1e-9] * 5]}
    z0 = [Q0, 0.0, *held(Q0), *[0.0] * 5]
    before = solve_ivp(rhs, (0.0, T_STEP), z0, args=(0.0,), **opts)
    after = solve_ivp(rhs, (T_STEP, T_LIFT), before.y[:, -1], args=(LS_CURRENT,), **opts)
    assert before.success and after.success
    return after.y[5:, -1]


@pytest.mark.parametrize("dt", [None, 1e-4], ids=["derived-step", "0.1ms"])
def test_the_energy_of_a_compensated_lift_on_a_load_sensing_pump_matches_radau(dt):
    """The boom lifted through its compensated section on its own load-sensing pump: the pump's
    energy, the meter-in, compensator and meter-out losses and the piston's work over the run
    against Radau of the equations with the powers integrated alongside. Measured: within
    2.4e-7 of the pump's energy at the derived step (0.5 ms), 1.0e-8 at 0.1 ms."""
    data = boom(valve={**VALVE, "compensator_margin": LS_COMPENSATOR})
    data["supply"] = {"pressure": PS, "max_flow": 1.0, "ls_margin": 15.0e5}
    run = ml.simulate(ml.ManipulatorSpec.from_dict(data),
                      inputs={"luff": ml.signals.step(LS_CURRENT, t0=T_STEP)}, duration=T_LIFT,
                      initial=initial(Q0), dt=dt, sample_dt=1e-2)
    report = energy_report(run)
    sim = np.array([report.total(t) for t in ("pump", "meter_in", "compensator", "meter_out",
                                              "work")])
    exact = _reference()
    assert exact[4] > 0.3 * exact[0] and exact[2] > 0.1 * exact[0]  # it lifted, compensated
    error = np.max(np.abs(sim - exact)) / exact[0]
    assert error < (2e-6 if dt is None else 1e-7), (sim, exact, error)
    assert abs(report.residual) < 1e-9 * report.pump


# --- 2. the balance on random runs of every arm with a pinned cylinder ------------------------

def _random_inputs(plant: ml.Plant, seed: int) -> dict[int, ml.sim.signals.Signal]:
    """A sine of random amplitude (up to 60 % of the command's range), frequency and phase on
    each joint."""
    rng = np.random.default_rng(seed)
    out = {}
    for j, actuator in enumerate(plant.actuators):
        limit = getattr(actuator, "command_limit", None)  # None: a passive joint's, ignored
        limit = 1.0 if limit is None else float(limit)
        out[j] = ml.signals.sine(0.6 * limit * rng.uniform(0.3, 1.0), rng.uniform(0.2, 0.7),
                                 rng.uniform(0.0, 6.0))
    return out


@pytest.mark.parametrize("arm_name", PINNED_ARMS,
                         ids=[a.rsplit("/", 1)[-1].removesuffix(".yaml") for a in PINNED_ARMS])
def test_the_balance_closes_on_random_runs_of_every_arm_with_a_pinned_cylinder(arm_name):
    """Random valve commands for 2 s: the pump's energy equals the losses, the tank line, the
    work and the compression to 1e-6 of it (measured: 1e-14); every loss is positive (the ideal
    anti-cavitation valve's, 0 in the limit, down to -3e-3 of the pump's: the excavator's arm
    driven into cavitation, see maniplab.sim.energy); and the
    work on the pistons the cylinders account is the work their forces did on the mechanics
    (∫ τ_act q̇ dt over the run's samples, MuJoCo's side), within the samples' trapezoid error."""
    plant = ml.Plant(arm_name)
    if not plant.energy:
        pytest.fail(f"{arm_name} has no pinned cylinder")
    run = ml.simulate(plant, duration=2.0, inputs=_random_inputs(plant, 7))
    report = energy_report(run)
    assert report.pump > 0.0
    assert abs(report.residual) < 1e-6 * report.pump
    for loss in LOSSES:  # the ideal anti-cavitation valve's is the step's error (see energy.py)
        least = -5e-3 if loss == "anticavitation" else -1e-12
        assert report.total(loss) >= least * report.pump, (loss, report.total(loss))
    joints = [plant.spec.joint_index(j) for j in report.joints]
    power = run["tau_act"][:, joints] * run.qd[:, joints]
    mechanics = trapezoid(power, run.t, axis=0)
    scale = max(report.pump, np.max(np.abs(report.terms["work"])))
    np.testing.assert_allclose(report.terms["work"], mechanics, atol=2e-3 * scale)


# --- 3. a fixed displacement pump -------------------------------------------------------------

def test_a_fixed_pump_with_its_valves_closed_puts_its_whole_flow_over_its_relief():
    """With every section closed, a fixed displacement pump delivers Q_max at its setting for the
    whole run, all of it over its relief: Q_max Ps T (closed form), and the sections nothing."""
    spec = ml.resolve_spec(f"{ROOT}/tests/arms/mixed/forestry_pump.yaml")
    run = ml.simulate(spec, duration=0.5, overrides={"supply.displacement": "fixed"})
    report = energy_report(run)
    supply = spec.supply
    assert supply is not None
    expected = supply.max_flow * supply.pressure * 0.5
    assert report.total("pump") < 1e-6 * expected
    assert report.pump_relief == pytest.approx(expected, rel=1e-9)


# --- 4. the command ---------------------------------------------------------------------------

def _maniplab(*args: str, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "maniplab", *args], check=False, cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def test_the_energy_command_compares_a_constant_pressure_and_a_load_sensing_pump(tmp_path):
    """The same duty cycle of the corpus forestry crane with its constant-pressure pump and with
    a load-sensing one: the table, the JSON and the figure; the load-sensing pump delivers less
    for the same work (its compensators throttle less), and every run's balance closes."""
    arm_file = f"{ROOT}/tests/arms/mixed/forestry_pump.yaml"
    cycle = ["--balanced", "--input", "lift=sine:0.8,0.3", "--input", "tilt=sine:-0.6,0.4"]
    for name, extra in (("constant", []), ("ls", ["--set", "supply.ls_margin=2e6"])):
        done = _maniplab("simulate", arm_file, "--duration", "3", *cycle, *extra, "-o",
                         f"{name}.npz", cwd=tmp_path)
        assert done.returncode == 0, done.stderr
    done = _maniplab("energy", "constant.npz", "ls.npz", "-o", "energy.png", "--json", "e.json",
                     cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    for term in TERMS:
        assert term in done.stdout
    assert "not accounted (lumped cylinders): slew, rotator" in done.stdout
    assert (tmp_path / "energy.png").stat().st_size > 10_000
    constant, ls = json.loads((tmp_path / "e.json").read_text())
    assert ls["pump"] < 0.85 * constant["pump"]
    assert sum(ls["terms"]["work"]) == pytest.approx(sum(constant["terms"]["work"]), rel=0.01)
    assert sum(ls["terms"]["compensator"]) < 0.6 * sum(constant["terms"]["compensator"])
    for report in (constant, ls):
        assert abs(report["residual"]) < 1e-9 * report["pump"]


def test_a_run_without_a_pinned_cylinder_is_one_line(tmp_path):
    done = _maniplab("simulate", "crane3", "--duration", "0.05", "-o", "c.npz", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    done = _maniplab("energy", "c.npz", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0
    assert "has no pinned cylinder" in done.stderr
    assert not (tmp_path / "out" / "energy.png").exists()
