"""Speed of the hydraulics inside MuJoCo (the engine plugins), each beside the bare RK4 step.

Run: ``python benchmarks/bench_native.py`` (about a minute). Prints a Markdown table for the
benchmarks page; times are medians of CPU time (``time.process_time``; wall time for the
threaded and multi-process rows), and the ratios, measured in the same run, are what to compare.

1. The erector (6 hydraulic joints, RK4, 1 ms), 10 s open loop under valve sines:
   the bare ``mj_step`` of the arm with its cylinders as MuJoCo's own inert actuators (the floor),
   plain ``mj_step`` of the exported MJCF (the plugins integrate eq. (4)), and maniplab's plant
   (``ml.simulate``) with friction ``none`` and with its hybrid stick/slip friction.
2. Two plain-MuJoCo plants in two threads against one (``mj_step`` releases the GIL).
3. An 8-variant payload sweep: ``mujoco.rollout`` (threads, no Python per step) against
   ``ml.sweep``'s process pool on the same 2 cores.
"""

from __future__ import annotations

import statistics
import tempfile
import threading
import time
from pathlib import Path

import mujoco
import numpy as np
from mujoco import rollout

import maniplab as ml

STEPS = 10_000  # 10 s at 1 ms
MASSES = [2000.0 + 500.0 * i for i in range(8)]
SINES = {f"q{j + 1}": ml.signals.sine(0.05 + 0.02 * j, 0.3 + 0.1 * j) for j in range(6)}


def timed(fn, repeats: int = 3, clock=time.process_time) -> float:
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
    """The same arm with the cylinders as plain MuJoCo actuators with two user activations and no
    callbacks (MuJoCo leaves them alone): the floor."""
    s = mujoco.MjSpec.from_string(ml.to_mjcf("erector"))
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


def main() -> None:
    spec = no_friction(ml.builtin_spec("erector"))
    with tempfile.TemporaryDirectory() as tmp:
        path = ml.mjcf_gen.writer.write_mjcf(spec, Path(tmp) / "erector.xml")
        exported = mujoco.MjModel.from_xml_path(str(path))
    ctrl = np.tile(0.05 * np.sin(np.linspace(0, 20, STEPS))[:, None], (1, 6))
    rows = []
    bare = inert()
    floor = timed(lambda: steps(bare, ctrl))
    rows.append(("bare RK4 mj_step, cylinders inert (the floor)", floor))
    rows.append(("plain mj_step of the exported MJCF (plugins)", timed(lambda: steps(exported, ctrl))))
    for name, arm in (("plant, friction none", spec), ("plant, hybrid friction", "erector")):
        plant = ml.Plant(arm)
        plant.balance_pressures()
        start = plant.save()

        def run(plant=plant, start=start):
            plant.restore(start)
            ml.simulate(plant, inputs=SINES, duration=10.0)

        rows.append((f"ml.simulate, {name}", timed(run)))

    def threads(k: int) -> None:
        workers = [threading.Thread(target=steps, args=(exported, ctrl)) for _ in range(k)]
        for w in workers:
            w.start()
        for w in workers:
            w.join()

    one = timed(lambda: threads(1), clock=time.perf_counter)
    two = timed(lambda: threads(2), clock=time.perf_counter)

    variants = [no_friction(ml.builtin_spec("erector").with_overrides({"end_effector.mass": m}))
                for m in MASSES]
    models = [ml.build_model(v) for v in variants]
    state = np.zeros((8, mujoco.mj_stateSize(models[0], mujoco.mjtState.mjSTATE_FULLPHYSICS)))
    controls = np.repeat(ctrl[None], 8, axis=0)
    datas = [mujoco.MjData(models[0]) for _ in range(2)]
    rolled = timed(lambda: rollout.rollout(models, datas, state, controls), 3, time.perf_counter)
    with tempfile.TemporaryDirectory() as tmp:
        pooled = timed(lambda: ml.sweep(ml.builtin_spec("erector").with_overrides(
            {f"joints.q{j}.friction.model": "none" for j in range(1, 7)}),
            {"end_effector.mass": MASSES}, out=Path(tmp) / "runs", inputs=SINES, duration=10.0,
            processes=2, progress=False), 1, time.perf_counter)

    print("| what (erector, 10 s at 1 ms) | time | vs the floor | real time |")
    print("|---|---|---|---|")
    for name, t in rows:
        print(f"| {name} | {t:.3f} s CPU | {t / floor:.2f}x | {10.0 / t:.0f}x |")
    print(f"| 2 threads of plain mj_step vs 1 | {two:.3f} s vs {one:.3f} s wall | "
          f"{2 * one / two:.2f}x throughput | |")
    print(f"| 8 payload variants: mujoco.rollout, 2 threads | {rolled:.3f} s wall | | "
          f"{80.0 / rolled:.0f}x |")
    print(f"| 8 payload variants: ml.sweep, 2 processes | {pooled:.3f} s wall | "
          f"rollout {pooled / rolled:.1f}x faster | {80.0 / pooled:.0f}x |")


if __name__ == "__main__":
    main()
