"""Identification: fit time against the number of parameters (1, 2, 4, 6, 8) on crane3.

Run: .venv/bin/python benchmarks/bench_identify.py [--repeats 3] [--sizes 1,2,4,6,8]

Synthetic data: crane3 with the first N parameters of ``TRUTH`` changed to their true values is
simulated from rest at the middle of its joint ranges, pressures balanced, under three
experiments (one per joint: up-and-down steps of the slew and the boom, a slow sine of the
telescope), each 5 s, recorded every 2 ms. The commands are sampled at that rate and held between
samples (``ml.signals.held``), as a fit replays them, and Gaussian noise is added to the measured
q (σ = 0.1 mrad or mm) and ΔP (σ = 0.1 bar) with a fixed seed. ``ml.identify`` then fits the N
parameters from crane3's own values. Printed per N: the median wall time of the fit, the
evaluations it ran (each simulates the three experiments), and each fitted value's error against
the truth (in % of the truth and in the fit's own standard deviations).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import maniplab as ml
from maniplab.builtin import resolve_spec
from maniplab.identification import Experiment, Identification
from maniplab.sim.grammar import parse_input

SPEC = "crane3"
TRUTH = {  # path -> (crane3's value, the start of the fit) and the true value
    "end_effector.mass": 120.0,                     # 100 kg
    "joints.luff.friction.coulomb": 75.0,           # 63 N·m
    "joints.telescope.friction.viscous": 280.0,     # 330 N·s/m
    "joints.slew.friction.coulomb": 130.0,          # 150 N·m
    "joints.luff.actuator.leakage": 2e-12,          # 1e-12 m³/(s·Pa)
    "joints.telescope.friction.coulomb": 250.0,     # 210 N
    "joints.slew.friction.viscous": 240.0,          # 200 N·m·s/rad
    "joints.luff.actuator.bulk_modulus": 0.8e9,     # 1e9 Pa
}
EXPERIMENTS = {
    "slew": "slew=step:0.5@0.5+step:-1@2.75",
    "luff": "luff=step:-0.5@0.5+step:1@2.75",
    "telescope": "telescope=sine:0.9,0.2@0.5",
}
DURATION = 5.0
SAMPLE_DT = 0.002
NOISE = {"q": 1e-4, "dP": 1e4}
"""σ of the measurement noise added: rad or m, Pa."""


def pose(spec: ml.ManipulatorSpec) -> dict[str, float]:
    return {j.name: 0.5 * (j.limits[0] + j.limits[1]) if j.limits else 0.0 for j in spec.joints}


def measure(truth: ml.ManipulatorSpec, seed: int = 0) -> list[Experiment]:
    """The experiments on the true arm, as a data logger would record them."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, DURATION + SAMPLE_DT / 2, SAMPLE_DT)
    out = []
    for name, text in EXPERIMENTS.items():
        joint, signal = parse_input(text)
        commands = {j: np.zeros_like(t) for j in truth.joint_names}
        commands[joint] = signal.sample(t)
        run = ml.simulate(truth, inputs={j: ml.signals.held(t, u) for j, u in commands.items()},
                          duration=DURATION, initial={"q": pose(truth), "dP": "gravity"},
                          sample_dt=SAMPLE_DT, progress=False)
        assert len(run.t) == len(t) and np.allclose(run.t, t)
        measured = {(s, j): run[s][:, k] + rng.normal(0.0, NOISE[s], len(t))
                    for s in NOISE for k, j in enumerate(truth.joint_names)}
        out.append(Experiment(name, t, commands, measured))
    return out


def fit(n: int, repeats: int) -> tuple[float, Identification, dict[str, float]]:
    """Median wall time of fitting the first n parameters, the last result and the truth."""
    spec = resolve_spec(SPEC)
    truth = dict(list(TRUTH.items())[:n])
    data = measure(spec.with_overrides(truth))
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = ml.identify(spec, data, list(truth), progress=False)
        times.append(time.perf_counter() - start)
    return statistics.median(times), result, truth


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sizes", default="1,2,4,6,8", help="numbers of parameters")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    rows, notes = [], []
    for n in sizes:
        wall, result, truth = fit(n, args.repeats)
        errors = []
        for p, value, std in zip(result.parameters, result.values, result.std):
            true = truth[p.path]
            sigmas = abs(value - true) / std if std > 0 else float("inf")
            errors.append(f"{p.path.split('.', 1)[1] if p.path.startswith('joints.') else p.path}"
                          f" {100 * (value - true) / true:+.2g} % ({sigmas:.1f} σ)")
        rows.append(f"| {n} | {wall:.1f} s | {result.evaluations} | {'; '.join(errors)} | "
                    f"{len(result.warnings)} |")
        notes += [f"- {n} parameters: {w}" for w in result.warnings]
        print(f"{n} parameters: {wall:.1f} s", flush=True)
    print(f"\ncrane3, 3 experiments x {DURATION:g} s at {1000 * SAMPLE_DT:g} ms, noise "
          f"q {NOISE['q']:g}, dP {NOISE['dP']:g} Pa; median of {args.repeats} fits on "
          f"{os.cpu_count()} cores:\n")
    print("| parameters | wall time | evaluations (each simulates the 3 experiments) | "
          "fitted - true (% of true, in fitted σ) | the fit's warnings |")
    print("|---|---|---|---|---|")
    print("\n".join(rows))
    if notes:
        print("\nThe fit's warnings:\n")
        print("\n".join(notes))


if __name__ == "__main__":
    main()
