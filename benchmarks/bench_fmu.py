"""The FMU: build time, and its simulation speed against maniplab's own run in the same session.

Run: .venv/bin/python benchmarks/bench_fmu.py [--repeats 5] [--arm erector]
(needs .venv-fmpy, which ``make test`` makes: FMPy without maniplab)

Printed (medians over the repeats):

* build: ``maniplab fmu`` (the plant checked, the C compiled, the FMU zipped), s.
* run, 5 s of the arm under a sine on every joint at the arm's default step:
  - the FMU in FMPy with one communication step per FMU step (FMPy sets the inputs and reads the
    outputs in Python between steps, as a co-simulation master does);
  - the FMU in FMPy with one communication step for the whole run (the FMU's own C loop);
  - against ``ml.simulate`` of the same run (the peer: the same plant in C, driven by maniplab),
  each as simulated seconds per wall-clock second and as a ratio to the peer.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import maniplab as ml
from maniplab.fmu import build_fmu
from maniplab.sim.plant import Plant

ROOT = Path(__file__).resolve().parents[1]
FMPY = ROOT / ".venv-fmpy" / "bin" / "python"
DURATION = 5.0

TIMER = """
import json, sys, time, numpy as np
from fmpy import simulate_fmu
cfg = json.loads(sys.argv[1])
t = np.arange(0.0, cfg["stop"] + cfg["dt"] / 2, cfg["dt"])
table = np.zeros(len(t), dtype=[("time", float)] + [(n, float) for n in cfg["inputs"]])
table["time"] = t
for name, amplitude in cfg["inputs"].items():
    table[name] = amplitude * np.sin(2 * np.pi * t)
times = []
for _ in range(cfg["repeats"]):
    began = time.perf_counter()
    simulate_fmu(cfg["fmu"], stop_time=cfg["stop"], output_interval=cfg["interval"], input=table)
    times.append(time.perf_counter() - began)
print(json.dumps(times))
"""


def _fmpy_times(fmu: Path, plant: Plant, interval: float, repeats: int) -> float:
    inputs = {f"u.{name}": 0.4 * (lim if np.isfinite(lim) else 1.0)
              for name, lim in zip(plant.joint_names, plant.command_limit)}
    cfg = {"fmu": str(fmu), "stop": DURATION, "dt": plant.dt, "interval": interval,
           "inputs": inputs, "repeats": repeats}
    out = subprocess.run([str(FMPY), "-c", TIMER, json.dumps(cfg)], capture_output=True,
                         text=True, check=True)
    return statistics.median(json.loads(out.stdout.strip().splitlines()[-1]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--arm", default="erector")
    args = parser.parse_args()
    spec = ml.resolve_spec(args.arm)
    plant = Plant(spec)
    with tempfile.TemporaryDirectory() as tmp:
        fmu = Path(tmp) / "arm.fmu"
        builds = []
        for _ in range(args.repeats):
            began = time.perf_counter()
            build_fmu(spec, fmu, progress=False)
            builds.append(time.perf_counter() - began)
        amplitudes = {name: 0.4 * (lim if np.isfinite(lim) else 1.0)
                      for name, lim in zip(plant.joint_names, plant.command_limit)}
        inputs = {name: (lambda t, a=a: a * np.sin(2 * np.pi * t))
                  for name, a in amplitudes.items()}
        peer = []
        for _ in range(args.repeats):
            began = time.perf_counter()
            ml.simulate(spec, inputs=inputs, duration=DURATION, progress=False)
            peer.append(time.perf_counter() - began)
        stepped = _fmpy_times(fmu, plant, plant.dt, args.repeats)
        whole = _fmpy_times(fmu, plant, DURATION, args.repeats)
        size = fmu.stat().st_size / 1e6
    base = statistics.median(peer)
    print(f"{spec.name}: {plant.n} joints, step {plant.dt:g} s, FMU {size:.1f} MB")
    print(f"build: {statistics.median(builds):.2f} s")
    for label, seconds in (("ml.simulate (peer)", base), ("FMU in FMPy, a step per step", stepped),
                           ("FMU in FMPy, one step of 5 s", whole)):
        print(f"{label:32s} {DURATION / seconds:8.1f} s/s   {seconds / base:6.2f} x the peer's time")


if __name__ == "__main__":
    main()
