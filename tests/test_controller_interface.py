"""Your own controller as a first-class citizen (issue 41): the interface (reset, output at a
sample time, declared signals with units, a reference for the verdict), python-control systems,
run_move and ``maniplab control --controller``, and sweeps on processes and Dask that give each
variant exactly the run it gives alone with a fresh controller."""

from __future__ import annotations

import textwrap
from pathlib import Path

import control as ct
import numpy as np
import pytest
from commandline import run_cli

import maniplab as ml
from maniplab.control.cascade import CascadeController
from maniplab.control.interface import Controller
from maniplab.control.lti import from_python_control
from maniplab.control.move import run_move
from maniplab.sim.sweep import sweep

TARGET = np.array([0.4, -0.3])


class JointPD(Controller):
    """A user's controller: PD on the joints of a torque arm, logging its error."""

    dt = 0.004
    log_signals = {"err": ("joint error", "rad"), "effort": ("|u|", "N·m")}  # noqa: RUF012

    def __init__(self, kp: float = 400.0, kd: float = 40.0) -> None:
        self.kp, self.kd, self.samples = kp, kd, 0

    def reset(self, state=None) -> None:
        super().reset(state)
        self.samples = 0

    def output(self, t, state):
        self.samples += 1
        err = TARGET - state.q
        u = self.kp * err - self.kd * state.qd
        self.log(err=err, effort=np.linalg.norm(u))
        return u


def test_your_controller_logs_its_signals_with_units_and_starts_afresh() -> None:
    pd = JointPD()
    first = ml.simulate("planar2", controller=pd, duration=0.2)
    second = ml.simulate("planar2", controller=pd, duration=0.2)
    assert pd.samples == 50  # reset: this run's samples only, every 4 ms of 0.2 s
    np.testing.assert_array_equal(first.q, second.q)
    assert first.units()["err"] == "rad" and first.units()["effort"] == "N·m"
    # the logged error is the plant's at each sample time, held in between (zero-order hold)
    k = np.searchsorted(first.t, 0.1 - 1e-12)
    np.testing.assert_allclose(first["err"][k], TARGET - first.q[k], rtol=1e-12)
    np.testing.assert_allclose(first["err"][k + 1], first["err"][k])
    assert np.isnan(first["err"]).sum() == 0  # the first sample is at t = 0


def test_a_python_control_system_runs_as_its_own_response_says() -> None:
    """The commands the plant received equal python-control's own forced response to the
    errors the controller saw (an independent evaluation of the same difference equations)."""
    dt = 0.005
    pid = ct.ss(ct.c2d(ct.tf([6.0, 60.0, 150.0], [1.0, 0.0]) * ct.tf([1.0], [0.01, 1.0]), dt))
    system = ct.append(pid, pid)
    spec = ml.builtin_spec("planar2")
    controller = from_python_control(system, spec, TARGET)
    run = ml.simulate(spec, controller=controller, duration=3.0, sample_dt=dt)
    errors = run["e"]
    response = ct.forced_response(system, U=errors.T, T=run.t)
    np.testing.assert_allclose(run["ctrl"][:-1], response.outputs.T[:-1], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(run.q[-1], TARGET, atol=1e-2)  # the integral takes the offset


@pytest.mark.parametrize("bad", [ct.tf([1.0], [1.0, 1.0]), ct.c2d(ct.tf([1.0], [1.0, 1.0]), 0.01)])
def test_a_continuous_or_mis_sized_system_is_refused_in_one_line(bad) -> None:
    with pytest.raises(ml.ManiplabError, match="discrete|inputs"):
        from_python_control(bad, ml.builtin_spec("planar2"), TARGET)


class PIDFactory:
    """A factory as ``maniplab control --controller`` takes it: (spec, move) -> controller, and
    the planned joint path, which the baseline tracks, when it asks for it."""

    def __call__(self, spec, move, *, joint_path=None):
        return CascadeController(spec, move, mode="pid", joint_path=joint_path)


def test_run_move_takes_your_controller_and_judges_it_on_its_reference() -> None:
    spec = ml.builtin_spec("crane3")
    ours = run_move(spec, [5.46, 0.6, 1.4], start=[0.0, 0.0, 0.5], duration=3.0, settle=0.3,
                    controller=PIDFactory())
    builtin = run_move(spec, [5.46, 0.6, 1.4], start=[0.0, 0.0, 0.5], duration=3.0, settle=0.3,
                       mode="pid")
    np.testing.assert_array_equal(ours.run.q, builtin.run.q)
    assert ours.run.label.startswith("PIDFactory")
    assert ours.run.meta["reference"]["final_mm"] == 2.0


def test_maniplab_control_runs_a_controller_from_a_file_on_a_corpus_arm(capsys, tmp_path) -> None:
    arm = Path(__file__).parent / "arms" / "loader_crane.yaml"
    source = tmp_path / "my_controller.py"
    source.write_text(textwrap.dedent("""
        from maniplab.control.cascade import CascadeController

        def cascade(spec, move):
            return CascadeController(spec, move)

        def baseline(spec, move):
            return CascadeController(spec, move, mode="pid")
    """))
    common = [str(arm), "--start=0,-0.6,1.2,0.5", "--target", "2.9,1.5,1.9", "--duration", "6",
              "--settle", "0.5"]
    code, out, err = run_cli(capsys, "control", *common, "--controller", f"{source}:cascade",
                             "-o", str(tmp_path / "ok"))
    assert code == 0, err
    assert '"verdict": "ok"' in out
    code, out, err = run_cli(capsys, "control", *common, "--controller", f"{source}:baseline",
                             "-o", str(tmp_path / "missed"))
    assert code == 3 and "missed its tolerances" in err.splitlines()[-1]
    assert '"verdict": "failed"' in out


@pytest.mark.parametrize("text", ["nomodule", "no_such_module_xyz:f", "/nonexistent.py:f",
                                  "maniplab:not_there"])
def test_a_controller_that_cannot_be_loaded_is_one_line_and_exit_2(capsys, tmp_path, text) -> None:
    code, _, err = run_cli(capsys, "control", "planar2", "--target", "1.2,0.5,0", "--duration",
                           "2", "--controller", text, "-o", str(tmp_path))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--controller" in err


@pytest.fixture(scope="module")
def sweep_case():
    spec = ml.builtin_spec("erector")
    am = ml.AnalyticModel(spec)
    q0 = np.array([-0.18, 1.27, 0.0, 0.0, 0.0, 0.0])
    start = ml.Pose.from_matrix(am.fk(q0))
    move = ml.MinJerkMove(start, start.translated((-0.3, 0.15, 0.0)), 0.6, t0=0.1)
    grid = {"end_effector.mass": [1.3 * spec.end_effector.mass, spec.end_effector.mass]}
    kw = {"duration": 0.8, "initial": {"q": q0, "dP": "gravity"}, "sample_dt": 0.01}
    alone = [ml.simulate(spec, overrides={"end_effector.mass": m},  # at the arm's step
                         controller=CascadeController(spec, move, model=am), **kw)
             for m in grid["end_effector.mass"]]
    return spec, CascadeController(spec, move, model=am), grid, kw, alone


@pytest.mark.parametrize("where", ["one process", "two processes", "dask"])
def test_a_sweep_gives_each_variant_its_run_alone(sweep_case, tmp_path, where) -> None:
    spec, controller, grid, kw, alone = sweep_case
    if where == "dask":
        import distributed
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                           dashboard_address=None, silence_logs=40)
        with cluster, distributed.Client(cluster) as client:
            runs = sweep(spec, grid, out=tmp_path, controller=controller, executor=client, **kw)
    else:
        runs = sweep(spec, grid, out=tmp_path, controller=controller,
                     processes=1 if where == "one process" else 2, **kw)
    assert not runs.failures
    for run, reference in zip(runs, alone):
        for name in ("q", "ctrl", "dP", "tau_d"):
            np.testing.assert_array_equal(run[name], reference[name], err_msg=name)
