"""Synthetic measurements for the identification tests: the plant with known true parameters,
inputs held at the data rate (as a digital controller's logged commands are), Gaussian noise."""

from __future__ import annotations

import numpy as np

import maniplab as ml
from maniplab.identification import Experiment

NOISE = {"q": 1e-4, "dP": 2e4}
"""σ of the measurement noise: 0.1 mrad (or 0.1 mm) on q, 0.2 bar on ΔP."""

RATE = 0.002
"""The data's sample interval, s (the plant steps at 1 ms)."""


def synthetic(spec: ml.ManipulatorSpec, truth: dict[str, float], inputs: dict[str, ml.signals.Signal],
              q0: list[float], duration: float, seed: int = 0,
              noise: dict[str, float] | None = None, rate: float = RATE,
              supply: object = None) -> Experiment:
    """An experiment on ``spec`` with ``truth`` applied, from rest at q0, sampled every ``rate``
    s, with the measurement noise ``noise`` (signal -> σ; default :data:`NOISE`) on each joint
    that has the signal; ``supply``: the rig's measured supply pressure (a signal, Pa), if any."""
    t = np.arange(0.0, duration + 1e-9, rate)
    held = {j: ml.signals.held(t, s.sample(t)) for j, s in inputs.items()}
    run = ml.simulate(spec.with_overrides(truth), inputs=held, duration=duration,
                      initial={"q": q0, "dP": "gravity"}, sample_dt=rate, supply=supply)
    rng = np.random.default_rng(seed)
    measured = {}
    for k, joint in enumerate(spec.joint_names):
        for signal, sigma in (NOISE if noise is None else noise).items():
            if not np.isnan(run[signal][:, k]).all():
                measured[(signal, joint)] = run[signal][:, k] + rng.normal(0.0, sigma, len(run.t))
    commands = {j: run["ctrl"][:, k] for k, j in enumerate(spec.joint_names)}
    return Experiment(f"synthetic {spec.name}", run.t, commands, measured)
