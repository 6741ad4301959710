"""A measured supply pressure as a run's input (``simulate(supply=...)``, ``--supply``): the
pinned cylinders' valves are fed at it instead of at their pump's, to validate an arm against a
rig's log (issue 34)."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from test_cylinder_physics import PS, Q0, Hydraulics, boom, initial

import maniplab as ml
from maniplab.sim.errors import InputError

RIPPLE = (0.25, 3.0)  # the measured pressure's swing (share of PS) and frequency (Hz)
T_OPEN, T_END = 0.1, 1.2


def measured(t: np.ndarray | float) -> np.ndarray | float:
    """The rig's supply pressure: a pump that sags and recovers, Pa."""
    share, hz = RIPPLE
    return PS * (1.0 - share * (0.5 - 0.5 * np.cos(2.0 * math.pi * hz * np.asarray(t))))


@functools.cache
def _reference() -> tuple:
    """Radau of the boom's equations (test_cylinder_physics) with the supply at measured(t)."""
    law = Hydraulics.of(boom()["joints"][0]["actuator"])

    def rhs(t: float, z: np.ndarray, iv: float) -> list[float]:
        return law.boom_rhs(t, z, iv, ps=float(measured(t)))

    opts = {"method": "Radau", "rtol": 1e-10, "atol": [1e-12, 1e-12, 1e-4, 1e-4, 1e-12],
            "dense_output": True}
    before = solve_ivp(rhs, (0.0, T_OPEN), [Q0, 0.0, *initial_state()], args=(0.0,), **opts)
    after = solve_ivp(rhs, (T_OPEN, T_END), before.y[:, -1], args=(0.6,), **opts)
    assert before.success and after.success
    return before.sol, after.sol


def initial_state() -> list[float]:
    state = initial(Q0)
    return [state["pA"][0], state["pB"][0], state["spool"][0]]


def test_a_boom_fed_at_a_measured_supply_matches_an_independent_integration() -> None:
    """The boom lifted while the measured supply sags by a quarter three times a second: q, pA
    and pB against Radau of the same equations with the supply a given function of time, within
    the 1e-3 of their ranges the derived step is for (measured: pA and pB 1.2e-4 at the derived
    0.5 ms, as with a constant supply; the supply linear over each step)."""
    run = ml.simulate(ml.ManipulatorSpec.from_dict(boom()), duration=T_END,
                      inputs={"luff": ml.signals.step(0.6, T_OPEN)}, initial=initial(Q0),
                      supply=measured, sample_dt=1e-3)
    before, after = _reference()
    ref = np.where(run.t <= T_OPEN, before(np.minimum(run.t, T_OPEN)),
                   after(np.maximum(run.t, T_OPEN)))
    assert run.q[0, 0] - run.q[-1, 0] > 0.1
    for name, sim, exact in (("q", run.q[:, 0], ref[0]), ("pA", run["pA"][:, 0], ref[2]),
                             ("pB", run["pB"][:, 0], ref[3])):
        error = np.max(np.abs(sim - exact)) / np.ptp(exact)
        assert error < 5e-4, f"{name}: {error:.3g} of its range"
    assert "measured" in run.meta["supply"]


def test_a_measured_supply_replaces_the_pump() -> None:
    """patu655 on a short load-sensing pump, fed instead at a measured constant 80 bar: the run
    is the run of the same arm on constant 80 bar supplies of its own, to the bit, and not the
    pump's; the measured supply ends with its run."""
    data = ml.resolve_spec("patu655").to_dict()
    own = ml.ManipulatorSpec.from_dict(data)
    data["supply"] = {"pressure": 8.0e6, "max_flow": 3.0e-4, "ls_margin": 2.0e6}
    pumped = ml.ManipulatorSpec.from_dict(data)
    inputs = {"lift": ml.signals.step(0.6, 0.05), "tilt": ml.signals.step(-0.5, 0.05)}
    start = {"q": [0.0, -0.3, 1.2], "dP": "gravity"}
    fed = ml.simulate(pumped, duration=0.4, inputs=inputs, initial=start, supply=8.0e6, dt=1e-3)
    alone = ml.simulate(own, duration=0.4, inputs=inputs, initial=start, dt=1e-3)
    for name in ("q", "pA", "pB", "spool"):
        np.testing.assert_array_equal(np.nan_to_num(fed[name]), np.nan_to_num(alone[name]))
    plant = ml.Plant(pumped, dt=1e-3)
    ml.simulate(plant, duration=0.2, inputs=inputs, initial=start, supply=8.0e6)
    assert not np.any(plant.data.userdata)  # the measured supply ended with its run
    pump = ml.simulate(pumped, duration=0.4, inputs=inputs, initial=start, dt=1e-3)
    # on its short pump (18 L/min) the lift's cap side rises far less than fed at 80 bar
    assert np.max(pump["pA"][:, 1]) < np.max(fed["pA"][:, 1]) - 5e5


@pytest.mark.parametrize("supply, words", [(-1.0, "-1 Pa at t = 0 s"),
                                           (float("nan"), "nan Pa at t = 0 s"),
                                           ("80 bar", "supply: ")])
def test_a_bad_measured_supply_is_one_line(supply, words: str) -> None:
    with pytest.raises(InputError, match="supply") as err:
        ml.simulate("patu655", duration=0.01, supply=supply)
    assert words in str(err.value) and "\n" not in str(err.value)


def _boom_file(tmp_path) -> str:
    path = tmp_path / "boom.yaml"
    import yaml

    path.write_text(yaml.safe_dump(boom()))
    return str(path)


def test_the_command_takes_a_measured_supply_as_a_signal_or_a_log(tmp_path, capsys) -> None:
    """``--supply`` as a signal expression and as a rig's CSV log give the runs the Python call
    gives with the same signal; a log with a bad pressure is one line naming file, line and
    column."""
    from commandline import run_cli

    spec_file = _boom_file(tmp_path)
    t = np.arange(0.0, 0.3 + 1e-9, 1e-3)
    log = tmp_path / "rig.csv"
    log.write_text("t,supply\n" + "".join(f"{float(x)!r},{float(measured(x))!r}\n" for x in t))
    common = ["simulate", spec_file, "--duration", "0.3", "--input", "luff=step:0.6@0.1"]
    for name, supply in (("a", "8e6+sine:5e5,2"), ("b", str(log))):
        code, _, err = run_cli(capsys, *common, "--supply", supply, "-o",
                               str(tmp_path / f"{name}.npz"))
        assert code == 0, err
    luff = {"luff": ml.signals.step(0.6, 0.1)}
    for name, supply in (("a", ml.signals.constant(8e6) + ml.signals.sine(5e5, 2.0)),
                         ("b", ml.signals.held(t, measured(t)))):
        expected = ml.simulate(spec_file, duration=0.3, inputs=luff, supply=supply)
        np.testing.assert_array_equal(ml.Run.load(tmp_path / f"{name}.npz")["pA"],
                                      expected["pA"])
    log.write_text("t,supply\n0.0,8e6\n0.001,-2\n0.002,8e6\n")
    code, _, err = run_cli(capsys, *common, "--supply", str(log))
    assert code == 2 and "rig.csv line 3, column 'supply'" in err and err.count("\n") == 1


def test_identification_feeds_the_simulations_at_the_measured_supply(tmp_path) -> None:
    """A rig whose pump sags as the boom lifts: its log has the supply pressure; the fit, fed at
    it, recovers the valve's nominal flow from five times off within its interval."""
    from identify_data import synthetic

    from maniplab.identification import identify, load_experiments

    spec = ml.ManipulatorSpec.from_dict(boom())
    flow = "joints.luff.actuator.valve.nominal_flow"
    truth = {flow: 9.0e-4}
    data = synthetic(spec, truth, {"luff": ml.signals.step(0.6, 0.1)}, [Q0], 0.6, rate=0.002,
                     noise={"q": 1e-4, "pA": 2e4, "pB": 2e4}, supply=measured)
    csv = tmp_path / "rig.csv"
    columns = {"t": data.t, "ctrl.luff": data.inputs["luff"], "supply": measured(data.t),
               **{f"{s}.{j}": v for (s, j), v in data.measured.items()}}
    csv.write_text(",".join(columns) + "\n" + "".join(
        ",".join(repr(float(c[i])) for c in columns.values()) + "\n" for i in range(len(data.t))))
    (experiment,) = load_experiments([csv], spec)
    np.testing.assert_allclose(experiment.supply, measured(data.t))
    start = spec.with_overrides({flow: 5.0 * truth[flow]})
    result = identify(start, [experiment], [flow], progress=False,
                      dt=ml.Plant(spec.with_overrides(truth)).dt)
    (value,), ((low, high),) = result.values, result.interval
    assert value == pytest.approx(truth[flow], rel=0.05)
    assert low <= truth[flow] <= high
