"""From a spec file to the MuJoCo model and the analytic model, checked against each other.

Writes your arm's MJCF (open it with `python -m mujoco.viewer --mjcf=OUT/arm.xml`), its analytic
model as Markdown and as a Python module, prints the joint table, and compares M(q) and the bias
forces of MuJoCo and the analytic model at a few random states.

    python examples/spec_to_mjcf.py my_arm.yaml -o out/my_arm      # or a built-in name: crane3
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

import maniplab as ml
from maniplab.atomic import write_text
from maniplab.model.export import export_model
from maniplab.summary import spec_table


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("spec", nargs="?", default="crane3", help="spec file or built-in name")
    parser.add_argument("-o", "--output", type=Path, default=Path("out/spec_to_mjcf"))
    args = parser.parse_args(argv)

    spec = ml.resolve_spec(args.spec)
    print(spec_table(spec))
    mjcf = ml.mjcf_gen.write_mjcf(spec, args.output / "arm.xml")
    write_text(args.output / "model.md", export_model(spec, "markdown", ("mass", "length")))
    write_text(args.output / "model.py", export_model(spec, "python", ()))

    model = mujoco.MjModel.from_xml_path(str(mjcf))  # the file, as any MuJoCo tool reads it
    data = mujoco.MjData(model)
    analytic = ml.AnalyticModel(spec)
    worst = 0.0
    for q, qd in np.random.default_rng(0).normal(size=(5, 2, spec.n)):
        data.qpos[:], data.qvel[:] = q, qd
        mujoco.mj_forward(model, data)
        M = np.zeros((spec.n, spec.n))
        mujoco.mj_fullM(model, data, M)
        worst = max(worst, np.linalg.norm(analytic.M(q) - M) / np.linalg.norm(M),
                    np.linalg.norm(analytic.bias(q, qd) - data.qfrc_bias)
                    / max(np.linalg.norm(data.qfrc_bias), 1e-12))
    print(f"\nwrote {mjcf}, {args.output / 'model.md'}, {args.output / 'model.py'}")
    print(f"MuJoCo vs analytic model, largest relative difference of M and bias: {worst:.1e}")
    return 0 if worst < 1e-9 else 1


if __name__ == "__main__":
    sys.exit(main())
