"""How the analytic model and long runs scale: 2 to 20 joints beside Pinocchio, 10 s to 1 h runs.

Model rows (random general arms from ``maniplab.sample.sample_arm``: full inertias, centres of
gravity off the links, a fifth of the joints prismatic): cold generation in a fresh process with an
empty cache (C and Python backends), the C compiler's peak memory, the C source size, and the
median time of one call from Python of inverse dynamics, M, G and the bias C q̇ + G, beside
Pinocchio's ``rnea``, ``crba``, ``computeGeneralizedGravity`` and ``nonLinearEffects`` on the same
arm (loaded from maniplab's MJCF) in the same run, with the ratio maniplab / Pinocchio.

Run rows (``long_runs.py``): wall time, stored MB and peak memory of erector runs.

    pip install -e '.[bench]'                      # Pinocchio ('pin')
    python benchmarks/bench_scaling.py             # ~3 minutes without the 1-hour run
    python benchmarks/bench_scaling.py --joints 6,12,20 --durations 10,60,600,3600
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from bench_model import per_call, pinocchio_model

import maniplab as ml
from maniplab.model import AnalyticModel
from maniplab.sample import sample_arm

_GENERATE = """
import json, resource, sys, time
from pathlib import Path
t0 = time.perf_counter()
import maniplab as ml
from maniplab.sample import sample_arm
spec = sample_arm({n}, seed={n})
t = time.perf_counter()
model = ml.AnalyticModel(spec, backend={backend!r})
seconds = time.perf_counter() - t
folder = Path(model._k.folder)
source = sum(p.stat().st_size for p in folder.iterdir() if p.suffix in (".c", ".py"))
peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
print(json.dumps({{"seconds": seconds, "compiler_mb": peak, "source_kb": source / 1024}}))
"""


def cold_generation(n: int, backend: str) -> dict[str, float]:
    """Generation in a fresh process with an empty cache: seconds, compiler peak MB, source KB."""
    with tempfile.TemporaryDirectory() as root:
        env = {**os.environ, "MANIPLAB_CACHE": root}
        out = subprocess.run([sys.executable, "-c", _GENERATE.format(n=n, backend=backend)],
                             env=env, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def call_times(n: int) -> dict[str, float]:
    """Median µs per call of maniplab's and Pinocchio's functions on the same arm."""
    spec = sample_arm(n, seed=n)
    am = AnalyticModel(spec, backend="c")
    q, qd, qdd = np.random.default_rng(n).uniform(-1, 1, size=(3, n))
    py = AnalyticModel(spec, backend="python")
    out = {"ID": per_call(lambda: am.inverse_dynamics(q, qd, qdd)),
           "ID Python": per_call(lambda: py.inverse_dynamics(q, qd, qdd), number=2000),
           "M": per_call(lambda: am.M(q)), "G": per_call(lambda: am.G(q)),
           "bias": per_call(lambda: am.bias(q, qd))}
    pin, pm = pinocchio_model(spec, Path(tempfile.mkdtemp()))
    if pin is None:
        return out
    data = pm.createData()
    out |= {"pin ID": per_call(lambda: pin.rnea(pm, data, q, qd, qdd)),
            "pin M": per_call(lambda: pin.crba(pm, data, q)),
            "pin G": per_call(lambda: pin.computeGeneralizedGravity(pm, data, q)),
            "pin bias": per_call(lambda: pin.nonLinearEffects(pm, data, q, qd))}
    tau = pin.rnea(pm, data, q, qd, qdd)
    out["agreement"] = float(np.linalg.norm(am.inverse_dynamics(q, qd, qdd) - tau)
                             / np.linalg.norm(tau))
    return out


def model_table(joints: list[int]) -> str:
    head = ("| joints | generation C, s | generation Python, s | compiler peak, MB | C source, KB "
            "| ID µs (Pinocchio rnea) | M µs (crba) | G µs (gravity) | C q̇ + G µs "
            "(nonLinearEffects) | ID µs, Python backend | agrees with Pinocchio |\n|" + "---|" * 11)
    rows = [head]
    for n in joints:
        c, py, t = cold_generation(n, "c"), cold_generation(n, "python"), call_times(n)

        def pair(key: str, t: dict[str, float] = t) -> str:
            if f"pin {key}" not in t:
                return f"{t[key]:.2f}"
            return f"{t[key]:.2f} ({t[f'pin {key}']:.2f}, ×{t[key] / t[f'pin {key}']:.2f})"

        agree = f"{t['agreement']:.0e}" if "agreement" in t else "-"
        rows.append(f"| {n} | {c['seconds']:.2f} | {py['seconds']:.2f} | {c['compiler_mb']:.0f} | "
                    f"{c['source_kb']:.0f} | {pair('ID')} | {pair('M')} | {pair('G')} | "
                    f"{pair('bias')} | {t['ID Python']:.1f} | {agree} |")
        print(rows[-1], flush=True)
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--joints", default="2,4,6,8,10,12,16,20")
    parser.add_argument("--durations", default="10,60,600",
                        help="erector run durations, s (add 3600 for the 1-hour run)")
    args = parser.parse_args()
    joints = [int(x) for x in args.joints.split(",") if x]
    print(f"maniplab {ml.__version__}, {os.cpu_count()} cores, Python {sys.version.split()[0]}")
    table = model_table(joints)
    print("\n" + table)
    durations = [float(x) for x in args.durations.split(",") if x]
    if durations:
        from long_runs import markdown, run_rows

        print("\n" + markdown(run_rows(tuple(durations))))


if __name__ == "__main__":
    main()
