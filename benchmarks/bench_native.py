"""Speed of the plant in C and the hydraulics inside MuJoCo, each beside the bare RK4 step.

Run: ``python benchmarks/bench_native.py`` (about a minute). Prints a Markdown table for the
benchmarks page; times are medians of CPU time (``time.process_time``; wall time for the
threaded and multi-process rows), and the ratios, measured in the same run, are what to compare.

1. The erector (6 hydraulic joints, RK4, 1 ms), 10 s open loop under valve sines:
   the bare ``mj_step`` of the arm with its cylinders as MuJoCo's own inert actuators (the floor),
   plain ``mj_step`` of the exported MJCF (the plugins integrate eq. (4)), and maniplab's plant
   (``ml.simulate``) with friction ``none`` and with its hybrid stick/slip friction.
2. The closed loop: the erector's acceptance move (1 m in 4 s, 5.5 s simulated) under the
   cascade controller at its derived rate.
3. Plants in two threads against one (``ml.simulate`` of the erector, hybrid friction): the plant
   in C releases the GIL for the whole run.
4. An 8-variant payload sweep: ``ml.sweep`` in threads (its default for arms that need no Python
   per step), ``ml.sweep`` on 2 processes, and ``mujoco.rollout`` of the exported models (plain
   MuJoCo, friction ``none``: no friction/limit automaton), on the same 2 cores.
5. The cost of an actuator written in Python: the erector with joint q6 driven by a one-state
   Python motor (MuJoCo's callbacks every RK4 stage) against the built-in torque source.
"""

from __future__ import annotations

import concurrent.futures as cf
import statistics
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import ClassVar

import mujoco
import numpy as np
from mujoco import rollout

import maniplab as ml
from maniplab.actuators import ActuatorPlugin, parameters
from maniplab.control.ik import inverse_kinematics
from maniplab.demo.erector import MOVE_Q0, acceptance_move

STEPS = 10_000  # 10 s at 1 ms
MASSES = [2000.0 + 500.0 * i for i in range(8)]
SINES = {f"q{j + 1}": ml.signals.sine(0.05 + 0.02 * j, 0.3 + 0.1 * j) for j in range(6)}


def timed(fn: Callable[[], object], repeats: int = 5,
          clock: Callable[[], float] = time.process_time) -> float:
    """Median seconds of ``fn()`` over ``repeats`` runs."""
    out = []
    for _ in range(repeats):
        start = clock()
        fn()
        out.append(clock() - start)
    return statistics.median(out)


def no_friction(spec: ml.ManipulatorSpec) -> ml.ManipulatorSpec:
    return spec.with_overrides({f"joints.{j.name}.friction.model": "none" for j in spec.joints})


def inert() -> mujoco.MjModel:
    """The floor: the erector as the plant steps it (MuJoCo's limits, dry friction and contacts
    off), with the cylinders as plain MuJoCo actuators with two user activations and no
    callbacks (MuJoCo leaves them alone)."""
    s = mujoco.MjSpec.from_string(ml.to_mjcf("erector"))
    s.option.disableflags |= (mujoco.mjtDisableBit.mjDSBL_LIMIT
                              | mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS
                              | mujoco.mjtDisableBit.mjDSBL_CONTACT)
    for act in s.actuators:
        act.plugin.active = False
        act.plugin.plugin_name = ""
        act.dyntype = mujoco.mjtDyn.mjDYN_USER
    while len(s.plugins):
        s.delete(s.plugins[0])
    return s.compile()


def steps(model: mujoco.MjModel, ctrl: np.ndarray) -> None:
    data = mujoco.MjData(model)
    for u in ctrl:
        data.ctrl[:] = u
        mujoco.mj_step(model, data)


@parameters
class LagParams:
    """A torque motor with a first-order lag (one state, in Python)."""

    tau: float = 0.01


class LagMotor(ActuatorPlugin):
    """τ' = (u - τ) / T, force τ: the simplest actuator with a state, written in Python."""

    Params: ClassVar[type] = LagParams
    states: ClassVar[tuple[str, ...]] = ("torque",)
    command: ClassVar[str] = "u"

    def derivatives(self, x: np.ndarray, u: float, q: float, v: float) -> np.ndarray:
        return np.array([(u - x[0]) / self.params.tau])

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        return float(x[0])

    def state_limits(self) -> tuple[float, ...]:
        return (1e9,)


def open_loop(rows: list[tuple[str, float]]) -> float:
    spec = no_friction(ml.builtin_spec("erector"))
    with tempfile.TemporaryDirectory() as tmp:
        path = ml.mjcf_gen.writer.write_mjcf(spec, Path(tmp) / "erector.xml")
        exported = mujoco.MjModel.from_xml_path(str(path))
    ctrl = np.tile(0.05 * np.sin(np.linspace(0, 20, STEPS))[:, None], (1, 6))
    bare = inert()
    floor = timed(lambda: steps(bare, ctrl))
    rows.append(("bare RK4 mj_step, cylinders inert (the floor)", floor))
    rows.append(("plain mj_step of the exported MJCF (plugins)",
                 timed(lambda: steps(exported, ctrl))))
    for name, arm in (("plant, friction none", spec), ("plant, hybrid friction", "erector")):
        plant = ml.Plant(arm)
        plant.balance_pressures()
        start = plant.save()

        def run(plant: ml.Plant = plant, start: np.ndarray = start) -> None:
            plant.restore(start)
            ml.simulate(plant, inputs=SINES, duration=10.0)

        rows.append((f"ml.simulate, {name}", timed(run)))
    return floor


def closed_loop() -> tuple[float, float, int]:
    """CPU seconds of the acceptance move under the cascade, its simulated time, its samples."""
    spec = ml.builtin_spec("erector")
    model = ml.AnalyticModel(spec)
    move = acceptance_move(model)
    q0 = inverse_kinematics(model, move.start, MOVE_Q0, task="position")
    duration = move.t0 + move.duration + 1.0
    samples = []

    def run() -> None:
        controller = ml.CascadeController(spec, move, task="position", model=model)
        ml.simulate(spec, controller=controller, duration=duration,
                    initial={"q": q0, "dP": "gravity"})
        samples.append(len(controller.times))

    return timed(run), duration, samples[-1]


def threads() -> tuple[float, float]:
    """Wall seconds of 10 s of one erector plant alone, and of two plants in two threads."""
    plants = [ml.Plant("erector") for _ in range(2)]
    for plant in plants:
        plant.balance_pressures()
    start = plants[0].save()

    def work(plant: ml.Plant) -> None:
        plant.restore(start)
        ml.simulate(plant, inputs=SINES, duration=10.0)

    def both() -> None:
        pair = [threading.Thread(target=work, args=(p,)) for p in plants]
        for t in pair:
            t.start()
        for t in pair:
            t.join()

    return timed(lambda: work(plants[0]), clock=time.perf_counter), timed(both, 5,
                                                                          time.perf_counter)


def sweeps() -> tuple[float, float, float]:
    """Wall seconds of the 8-variant payload sweep: ml.sweep in threads and on 2 processes, and
    mujoco.rollout of the exported models (friction none)."""
    grid = {"end_effector.mass": MASSES}
    with tempfile.TemporaryDirectory() as tmp:
        def threaded() -> None:
            ml.sweep("erector", grid, out=Path(tmp) / "t", inputs=SINES, duration=10.0,
                     processes=2, progress=False)

        def pooled() -> None:
            with cf.ProcessPoolExecutor(2) as pool:
                ml.sweep("erector", grid, out=Path(tmp) / "p", inputs=SINES, duration=10.0,
                         executor=pool, progress=False)

        in_threads = timed(threaded, 3, time.perf_counter)
        in_processes = timed(pooled, 3, time.perf_counter)
    models = [ml.build_model(no_friction(ml.builtin_spec("erector").with_overrides(
        {"end_effector.mass": m}))) for m in MASSES]
    state = np.zeros((8, mujoco.mj_stateSize(models[0], mujoco.mjtState.mjSTATE_FULLPHYSICS)))
    ctrl = np.tile(0.05 * np.sin(np.linspace(0, 20, STEPS))[:, None], (1, 6))
    datas = [mujoco.MjData(models[0]) for _ in range(2)]
    rolled = timed(lambda: rollout.rollout(models, datas, state, np.repeat(ctrl[None], 8, 0)), 3,
                   time.perf_counter)
    return in_threads, in_processes, rolled


def python_actuator() -> tuple[float, float]:
    """CPU seconds of 10 s of the erector with q6 a Python motor, and with a torque source."""
    base = ml.builtin_spec("erector")
    times = []
    for actuator in ({"type": "torque"}, {"type": f"{__name__}:LagMotor"}):
        spec = base.with_overrides({"joints.q6.actuator": actuator})
        times.append(timed(lambda spec=spec: ml.simulate(
            spec, inputs=SINES, duration=10.0, initial={"dP": "gravity"}), 3))
    return times[0], times[1]


def main() -> None:
    rows: list[tuple[str, float]] = []
    floor = open_loop(rows)
    loop, duration, samples = closed_loop()
    one, two = threads()
    in_threads, in_processes, rolled = sweeps()
    torque, python = python_actuator()
    print("| what (erector, 10 s at 1 ms) | time | vs the floor | real time |")
    print("|---|---|---|---|")
    for name, t in rows:
        print(f"| {name} | {t:.3f} s CPU | {t / floor:.2f}x | {10.0 / t:.0f}x |")
    print(f"| closed loop, acceptance move ({duration:g} s, {samples} cascade samples) | "
          f"{loop:.3f} s CPU | {loop / (floor * duration / 10.0):.2f}x | {duration / loop:.0f}x |")
    print(f"| 2 plants in 2 threads vs 1 (ml.simulate, hybrid friction) | {two:.3f} s vs "
          f"{one:.3f} s wall | {2 * one / two:.2f}x throughput | |")
    print(f"| 8 payload variants: ml.sweep, threads (default) | {in_threads:.3f} s wall | | "
          f"{80.0 / in_threads:.0f}x |")
    print(f"| 8 payload variants: ml.sweep, 2 processes | {in_processes:.3f} s wall | threads "
          f"{in_processes / in_threads:.1f}x faster | {80.0 / in_processes:.0f}x |")
    print(f"| 8 payload variants: mujoco.rollout of the exported models, friction none | "
          f"{rolled:.3f} s wall | | {80.0 / rolled:.0f}x |")
    print(f"| q6 a Python actuator vs MuJoCo's motor (ml.simulate) | {python:.3f} s vs "
          f"{torque:.3f} s CPU | {python / torque:.1f}x slower | {10.0 / python:.0f}x |")


if __name__ == "__main__":
    main()
