"""Speed of the analytic model on the erector, against MuJoCo and Pinocchio in the same run.

Prints medians and ratios: cold generation (empty cache), warm load (a new process with the cache
filled), per-call time from Python of inverse dynamics and of M + C q̇ + G, and a batch of 10,000
states against a Python loop over Pinocchio. Not part of the test suite.

    pip install -e '.[bench]'            # Pinocchio ('pin'); without it its columns are skipped
    python benchmarks/bench_model.py     # ~1 minute
"""

from __future__ import annotations

import ctypes
import os
import statistics
import subprocess
import sys
import tempfile
import timeit
from pathlib import Path

import mujoco
import numpy as np

import maniplab as ml
from maniplab.model import AnalyticModel, build

SPEC = "erector"
BATCH = 10_000


def per_call(fn, number: int = 20_000, repeat: int = 7) -> float:
    """Median time of one call, µs."""
    return statistics.median(timeit.repeat(fn, number=number, repeat=repeat)) / number * 1e6


def cold_generation(spec: ml.ManipulatorSpec, backend: str, runs: int = 3) -> float:
    """Median seconds to generate, compile and load with an empty cache (in this process)."""
    times = []
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as root:
            os.environ["MANIPLAB_CACHE"] = root
            build._LOADED.clear()
            start = timeit.default_timer()
            AnalyticModel(spec, backend=backend)
            times.append(timeit.default_timer() - start)
    return statistics.median(times)


def warm_load(backend: str, root: str, runs: int = 5) -> float:
    """Median seconds for AnalyticModel(spec) in a new process whose cache holds the model."""
    code = (f"import time, maniplab as ml; s = ml.builtin_spec({SPEC!r}); t = time.perf_counter(); "
            f"ml.AnalyticModel(s, backend={backend!r}); print(time.perf_counter() - t)")
    env = {**os.environ, "MANIPLAB_CACHE": root}
    subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True)
    out = [float(subprocess.run([sys.executable, "-c", code], env=env, check=True,
                                capture_output=True, text=True).stdout) for _ in range(runs)]
    return statistics.median(out)


def pinocchio_model(spec: ml.ManipulatorSpec, folder: Path):
    """Pinocchio's model of the same MJCF, or None when Pinocchio is not installed."""
    try:
        import pinocchio as pin
    except ImportError:
        return None, None
    path = folder / f"{spec.name}.xml"
    path.write_text(ml.to_mjcf(spec))
    model = pin.buildModelFromMJCF(str(path))
    model.gravity.linear = np.array(spec.gravity)  # the MJCF parser keeps its default gravity
    return pin, model


def main() -> None:
    spec = ml.builtin_spec(SPEC)
    n = spec.n
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.uniform(-1, 1, size=(3, n))
    Q, QD, QDD = rng.uniform(-1, 1, size=(3, BATCH, n))
    rows: list[tuple[str, str, str]] = []

    def row(what: str, value: str, note: str = "") -> None:
        rows.append((what, value, note))

    AnalyticModel(spec, backend="python", cache=False)  # imports out of the timings
    gen_c = cold_generation(spec, "c")
    gen_py = cold_generation(spec, "python")
    row("cold generation, C backend (empty cache)", f"{gen_c:.2f} s", "target <= 3 s")
    row("cold generation, Python backend", f"{gen_py:.2f} s", "")
    with tempfile.TemporaryDirectory() as root:
        os.environ["MANIPLAB_CACHE"] = root
        build._LOADED.clear()
        am = AnalyticModel(spec, backend="c")
        py = AnalyticModel(spec, backend="python")
        row("warm load, C backend (new process)", f"{warm_load('c', root) * 1e3:.1f} ms",
            "target <= 200 ms")
        row("warm load, Python backend (new process)", f"{warm_load('python', root) * 1e3:.1f} ms", "")
        so = ctypes.CDLL(str(next(Path(am._k.folder).glob("*.so"))))

    m = ml.build_model(spec)
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:], d.qacc[:] = q, qd, qdd

    def mj_inverse_with_state() -> None:
        d.qpos[:] = q
        d.qvel[:] = qd
        d.qacc[:] = qdd
        mujoco.mj_inverse(m, d)

    t_id = per_call(lambda: am.inverse_dynamics(q, qd, qdd))
    t_raw = per_call(lambda: am._k.inverse_dynamics(am.params, q, qd, qdd))
    t_mb = per_call(lambda: am.mass_and_bias(q, qd))
    t_sep = per_call(lambda: (am.M(q), am.C(q, qd) @ qd + am.G(q)))
    t_mjinv = per_call(lambda: mujoco.mj_inverse(m, d))
    t_mjinv_state = per_call(mj_inverse_with_state)
    t_py = per_call(lambda: py.inverse_dynamics(q, qd, qdd), number=2000)

    dp = ctypes.POINTER(ctypes.c_double)
    fn = so.ml_inverse_dynamics
    fn.argtypes, fn.restype = [dp] * 5, None
    out = np.zeros(n)

    def via_ctypes() -> np.ndarray:
        fn(am.params.ctypes.data_as(dp), q.ctypes.data_as(dp), qd.ctypes.data_as(dp),
           qdd.ctypes.data_as(dp), out.ctypes.data_as(dp))
        return out

    t_ctypes = per_call(via_ctypes)

    pin, pm = pinocchio_model(spec, Path(tempfile.mkdtemp()))
    if pin is not None:
        pdata = pm.createData()
        err = np.abs(pin.rnea(pm, pdata, q, qd, qdd) - am.inverse_dynamics(q, qd, qdd)).max()
        t_rnea = per_call(lambda: pin.rnea(pm, pdata, q, qd, qdd))
        t_crba_nle = per_call(lambda: (pin.crba(pm, pdata, q), pin.nonLinearEffects(pm, pdata, q, qd)))
    ratio = (lambda t: f"{t / t_rnea:.2f}x rnea, {t / t_mjinv:.2f}x mj_inverse") if pin else \
        (lambda t: f"{t / t_mjinv:.2f}x mj_inverse")
    row("inverse_dynamics, C backend", f"{t_id:.2f} µs", ratio(t_id) + "; target <= 1.5x rnea")
    row("  the extension function alone (no method)", f"{t_raw:.2f} µs", ratio(t_raw))
    row("  the same C kernel through ctypes", f"{t_ctypes:.2f} µs", ratio(t_ctypes))
    both = (lambda t: f"{t / t_crba_nle:.2f}x crba + nonLinearEffects, ") if pin else (lambda t: "")
    row("mass_and_bias (M and C q̇ + G, one call)", f"{t_mb:.2f} µs", both(t_mb) + ratio(t_mb))
    row("M(q), C(q, q̇) @ q̇ + G(q) (three calls)", f"{t_sep:.2f} µs", both(t_sep) + ratio(t_sep))
    row("inverse_dynamics, Python backend", f"{t_py:.1f} µs", ratio(t_py))
    row("MuJoCo mj_inverse (state already set)", f"{t_mjinv:.2f} µs", "")
    row("MuJoCo mj_inverse (setting qpos, qvel, qacc)", f"{t_mjinv_state:.2f} µs", "")
    if pin is not None:
        row("Pinocchio rnea", f"{t_rnea:.2f} µs", f"agrees with the model to {err:.1e}")
        row("Pinocchio crba + nonLinearEffects", f"{t_crba_nle:.2f} µs", "")

    t_batch = per_call(lambda: am.inverse_dynamics(Q, QD, QDD), number=5, repeat=5) / BATCH
    t_batch_py = per_call(lambda: py.inverse_dynamics(Q, QD, QDD), number=1, repeat=3) / BATCH
    t_batch_m = per_call(lambda: am.mass_and_bias(Q, QD), number=5, repeat=5) / BATCH
    row(f"batch of {BATCH} states, inverse_dynamics (C)", f"{t_batch * 1e3:.0f} ns/state", "")
    row(f"batch of {BATCH} states, mass_and_bias (C)", f"{t_batch_m * 1e3:.0f} ns/state", "")
    row(f"batch of {BATCH} states, inverse_dynamics (Python, numpy)", f"{t_batch_py * 1e3:.0f} ns/state", "")
    if pin is not None:
        def pin_loop() -> None:
            for i in range(BATCH):
                pin.rnea(pm, pdata, Q[i], QD[i], QDD[i])
        t_loop = per_call(pin_loop, number=1, repeat=3) / BATCH
        row(f"Python loop over Pinocchio rnea, {BATCH} states", f"{t_loop * 1e3:.0f} ns/state",
            f"batch C is {t_loop / t_batch:.1f}x faster per state")

    ops = {k.name: k.ops for k in build.generate(spec).kernels}
    print(f"# maniplab analytic model, {SPEC} ({n} DOF), Python {sys.version.split()[0]}, "
          f"numpy {np.__version__}, mujoco {mujoco.__version__}"
          + (f", pinocchio {pin.__version__}" if pin else ", pinocchio not installed"))
    print(f"# operations recorded per kernel: {ops}\n")
    width = max(len(r[0]) for r in rows)
    print(f"| {'what':<{width}} | median | note |\n|{'-' * (width + 2)}|---|---|")
    for what, value, note in rows:
        print(f"| {what:<{width}} | {value} | {note} |")


if __name__ == "__main__":
    main()
