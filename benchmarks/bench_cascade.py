"""Per-sample time of the cascade controller in C against the Python composition it replaced.

On the erector's acceptance move (1 m in 4 s, the pose task, 200 Hz), the states the controller
saw in a closed-loop run (``ml.simulate``) are replayed, in the same process:

- the C sample as the plant's run loop calls it: ``ml_cascade_control`` (``controller.native``)
  through ctypes on an MjData per recorded state, with the ctypes call's own cost (a call the
  function refuses at once) measured alongside and subtracted;
- ``CascadeController.step``, the Python path: the trajectory sampled in Python, then the same C
  sample through ctypes;
- the frozen Python composition of the public blocks (PID, DampedLeastSquares, Kinematics,
  InverseDynamics, PressureLoop, tests/reference/cascade.py), which is what ``step`` computed
  before the sample moved to C;

and the whole closed loop once more (``ml.simulate``, the cascade inside the plant's C loop).

Medians of REPEAT passes over all states (wall time, ``time.perf_counter``); the ratio measured in
one run is the figure to compare. Not part of the test suite.

    python benchmarks/bench_cascade.py
"""

from __future__ import annotations

import ctypes
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

import maniplab as ml
from maniplab.control.ik import inverse_kinematics

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from reference.cascade import ReferenceCascade

from maniplab.demo.erector import MOVE_Q0, acceptance_move

REPEAT = 7
CONTROLLER = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_double, ctypes.c_void_p,
                              ctypes.c_void_p, ctypes.POINTER(ctypes.c_double))


class Recorder:
    """Passes the calls on to the controller and keeps the plant states it was called with."""

    def __init__(self, controller: ml.CascadeController) -> None:
        self.controller, self.dt = controller, controller.dt
        self.states: list[tuple[float, np.ndarray, np.ndarray, np.ndarray]] = []

    def __call__(self, t: float, state: Any) -> np.ndarray:
        self.states.append((t, np.array(state.q), np.array(state.qd), np.array(state.dP)))
        return self.controller(t, state)


def median_per_sample(run: Any, samples: int) -> float:
    """Median over REPEAT passes of one pass's time per sample, µs."""
    times = []
    for _ in range(REPEAT):
        start = time.perf_counter()
        run()
        times.append((time.perf_counter() - start) / samples * 1e6)
    return statistics.median(times)


def main() -> int:
    spec = ml.builtin_spec("erector")
    model = ml.AnalyticModel(spec)
    move = acceptance_move(model)
    q0 = inverse_kinematics(model, move.start, MOVE_Q0)
    recorder = Recorder(ml.CascadeController(spec, move, model=model))
    ml.simulate(spec, controller=recorder, duration=move.t0 + move.duration + 1.0,
                initial={"q": q0, "dP": "gravity"})
    states = recorder.states
    times = np.array([s[0] for s in states])
    count = len(states)

    # the native function on an MjData per state (q, qd and each cylinder's dP in act)
    controller = ml.CascadeController(spec, move, model=model)
    m = ml.build_model(spec)
    datas = []
    for _, q, qd, dP in states:
        d = mujoco.MjData(m)
        d.qpos[:], d.qvel[:] = q, qd
        d.act[m.actuator_actadr] = dP
        datas.append(d)
    u = np.zeros(spec.n)
    out = u.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
    calls = [(float(t), d._address) for t, d in zip(times, datas)]

    def native_pass(refused: bool = False) -> None:
        controller.reset()
        native = controller.native(None, times)
        assert native is not None
        function, context = CONTROLLER(native.function), native.context
        for t, address in calls:
            status = function(context, -1.0 if refused else t, m._address, address, out)
            assert (status != 0) == refused, native.message()

    def step_pass() -> None:
        controller.reset()
        for t, q, qd, dP in states:
            controller.step(t, q, qd, dP=dP)

    def reference_pass() -> None:
        reference = ReferenceCascade(controller)
        for t, q, qd, dP in states:
            reference.step(t, q, qd, dP=dP)

    def closed_loop() -> float:
        """The whole run through ml.simulate, the cascade inside the plant's C loop, s (wall)."""
        start = time.perf_counter()
        ml.simulate(spec, controller=ml.CascadeController(spec, move, model=model),
                    duration=duration, initial={"q": q0, "dP": "gravity"})
        return time.perf_counter() - start

    duration = move.t0 + move.duration + 1.0
    native_pass()  # warm up (builds nothing, but touches every page)
    c_call = median_per_sample(native_pass, count)
    overhead = median_per_sample(lambda: native_pass(refused=True), count)
    python_path = median_per_sample(step_pass, count)
    frozen = median_per_sample(reference_pass, count)
    loop = statistics.median(closed_loop() for _ in range(REPEAT))
    c_only = c_call - overhead
    rows = [
        ("C sample (ml_cascade_control), ctypes call overhead subtracted", c_only, 1.0),
        ("C sample through ctypes, as called from Python", c_call, c_call / c_only),
        ("ctypes call overhead alone (a call refused at once)", overhead, overhead / c_only),
        ("CascadeController.step (Python path: trajectory + C sample)", python_path,
         python_path / c_only),
        ("frozen Python composition of the blocks (before)", frozen, frozen / c_only),
    ]
    print(f"erector, {spec.n} joints, pose task, {controller.rate:g} Hz: {count} recorded "
          f"samples of the acceptance move; medians of {REPEAT} passes (wall)\n")
    width = max(len(r[0]) for r in rows)
    print(f"| {'what'.ljust(width)} | µs per sample | × C sample |\n|{'-' * (width + 2)}|---|---|")
    for what, value, ratio in rows:
        print(f"| {what.ljust(width)} | {value:.2f} | {ratio:.1f} |")
    print(f"\nC sample {frozen / c_only:.0f}x faster than the Python composition; the closed "
          f"loop ({duration:g} s through ml.simulate, the cascade in the plant's C loop): "
          f"{loop:.3f} s, {duration / loop:.0f}x real time")
    return 0


if __name__ == "__main__":
    sys.exit(main())
