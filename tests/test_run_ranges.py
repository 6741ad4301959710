"""Every number that sets a run's length is checked before it reaches C (issue 40, finding 1).

At the commit before this test a step of 1e-200 s killed the process with SIGFPE (the step count
and the recording interval overflowed the C loop's 64-bit counters and ``k % every`` divided by
zero), a step of 1e-22 s ran for minutes with no answer, and a duration of 1e308 s ended in an
OverflowError traceback. Each now gets one line and exit status 2; the C loop itself refuses a
run whose counts are out of range, whoever calls it, and a NaN command never becomes a full
reverse command.
"""

from __future__ import annotations

import ctypes
import math
import subprocess
import sys

import numpy as np
import pytest
from commandline import run_cli

import maniplab as ml
from maniplab.sim import budget, native
from maniplab.sim.errors import InputError
from maniplab.sim.plant import Plant


@pytest.mark.parametrize(("args", "field"), [
    (["--dt", "1e-200", "--duration", "1"], "dt"),
    (["--dt", "1e-22", "--duration", "1"], "dt"),
    (["--duration", "1e308"], "duration"),
    (["--duration", "1e300", "--dt", "1"], "duration"),
])
def test_a_step_or_duration_out_of_range_is_one_line_and_exit_2(
        tmp_path, args: list[str], field: str) -> None:
    out = tmp_path / "run.npz"
    done = subprocess.run([sys.executable, "-m", "maniplab", "simulate", "erector", *args,
                           "-o", str(out)], capture_output=True, text=True, timeout=120,
                          check=False)
    assert done.returncode == 2, done.stderr[-2000:]
    lines = [line for line in done.stderr.strip().splitlines()  # a warning may come first
             if not line.startswith("maniplab simulate: warning: ")]
    assert len(lines) == 1 and lines[0].startswith("maniplab simulate: ")
    assert field in lines[0] and "Traceback" not in done.stderr
    assert not out.exists()


@pytest.mark.parametrize("duration", [math.nan, math.inf, -1.0, 0.0, 1e308, True, "2"])
def test_simulate_refuses_a_duration_out_of_range(duration) -> None:
    with pytest.raises(InputError, match="duration"):
        ml.simulate("planar2", duration=duration)


@pytest.mark.parametrize("dt", [math.nan, -1e-3, 0.0, 1e-308, 1e-10, math.inf])
def test_a_plant_refuses_a_step_out_of_range(dt: float) -> None:
    with pytest.raises(InputError, match="dt"):
        Plant("planar2", dt=dt)


def test_the_shortest_step_still_runs() -> None:
    run = ml.simulate("planar2", dt=budget.MIN_DT, duration=20 * budget.MIN_DT,
                      sample_dt=budget.MIN_DT)
    assert len(run.t) == 21 and np.isfinite(run.q).all()


def test_a_huge_recording_interval_records_the_first_and_last_sample() -> None:
    run = ml.simulate("planar2", duration=0.01, sample_dt=1e300)
    np.testing.assert_allclose(run.t, [0.0, 0.01])


@pytest.mark.parametrize("t", [math.nan, math.inf, 1e300])
def test_a_start_time_out_of_range_is_refused(t: float) -> None:
    with pytest.raises(InputError, match="t must be"):
        Plant("planar2").set_state(t=t)


@pytest.mark.parametrize("change", [{"every": 0}, {"every": -3}, {"steps": -1}, {"dt": 0.0},
                                    {"dt": math.nan}, {"k": -5}, {"rows": -1}])
def test_the_c_loop_refuses_counts_out_of_range_whoever_calls_it(change: dict) -> None:
    """ml_plant_run called with a bad ml_run (as a caller without maniplab's checks would):
    a status, never a division by zero or a write outside the buffers."""
    plant = Plant("planar2")
    held = np.zeros(plant.n)
    fields = {"steps": 10, "t0": 0.0, "dt": plant.dt, "k": 0, "max_steps": 0, "inputs": None,
              "inputs_k0": 0, "held": native.pointer(held), "controller": None,
              "controller_context": None, "period": 0.0, "next_call": 0.0, "every": 1,
              "rows": 0, "ee_body": -1}
    run = native.RunStruct(**{**fields, **change})
    assert plant._c.run(run) == native.BAD_RUN
    with pytest.raises(InputError, match="out of range"):
        plant.check(native.BAD_RUN)
    assert plant.t == 0.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("arm", ["erector", "planar2"])
def test_prepare_refuses_a_command_that_is_not_finite(arm: str, bad: float) -> None:
    """Before: NaN was clipped to the lower command limit (-1 A on the erector: full reverse)
    or recorded as -inf on an arm without a command limit."""
    plant = Plant(arm)
    u = [0.0] * plant.n
    u[-1] = bad
    with pytest.raises(InputError, match=f"joint {plant.joint_names[-1]}: .*not a finite"):
        plant.prepare(u)
    with pytest.raises(RuntimeError, match="prepare"):
        plant.advance()  # the refused step was not prepared
    plant.prepare([0.0] * plant.n)  # the plant goes on
    plant.advance()
    assert plant.record.u == [0.0] * plant.n and plant.t == pytest.approx(plant.dt)


def test_the_run_structure_mirror_matches_c() -> None:
    """The status numbers Python reads are plant.h's (BAD_RUN is the newest)."""
    assert (native.OK, native.BAD_COMMAND, native.BAD_RUN) == (0, 4, 7)
    assert ctypes.sizeof(native.RunStruct) > 0


@pytest.mark.parametrize("argv", [
    ["control", "planar2", "--target", "1.2,0.5,0", "--duration", "1e308"],
    ["sweep", "planar2", "--vary", "end_effector.mass=1,2", "--duration", "1e300"],
    ["sweep", "planar2", "--vary", "end_effector.mass=1,2", "--duration", "nan"],
])
def test_control_and_sweep_refuse_a_duration_out_of_range_before_any_work(
        capsys, tmp_path, argv: list[str]) -> None:
    """Before: control ended in an OverflowError traceback; sweep failed every variant (exit 3)."""
    code, _, err = run_cli(capsys, *argv, "-o", str(tmp_path / "out"))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "duration" in err
    assert not (tmp_path / "out").exists()


def test_a_huge_step_is_refused_in_one_line_not_an_overflow() -> None:
    """Found by the sanitizer fuzz: Plant(dt=1e308) ended in an OverflowError traceback."""
    with pytest.raises(ml.ManiplabError, match="more than 1000 sub-steps"):
        Plant("erector", dt=1e308)
