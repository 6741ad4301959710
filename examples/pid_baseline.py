"""The PID-only baseline (no feedback linearisation) against the full cascade, on the erector.

The baseline maps the Cartesian error to joint errors with the same damped least squares and
drives each valve with a joint PID (output: a joint speed, turned into current through the
valve's no-load gain). Its gains are those derived from the arm (``maniplab tune``); ``--tune``
runs a grid search instead (kp, ki, kd over a grid; the smallest RMS error on the acceptance move
with a final error under 10 mm, among the gains that also keep the segment placement stable), to
compare the rule with the best gains for this one arm. Prints the tables and the RMS ratios.

    python examples/pid_baseline.py -o out/examples          # with the derived gains
    python examples/pid_baseline.py -o out/examples --tune   # redo the grid search first
"""

from __future__ import annotations

import itertools
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from _validation import (
    MOVE_Q0,
    PICK_Q0,
    acceptance_move,
    dump_json,
    parse_args,
    placement_path,
    ratio_line,
    report,
    run_case,
)

import maniplab as ml
from maniplab.control.tuning import resolve
from maniplab.spec import JointPIDGains

GRID = {"kp": (1.0, 2.0, 3.0, 4.0, 6.0), "ki": (16.0, 32.0, 64.0, 96.0, 128.0, 192.0, 256.0),
        "kd": (0.0, 0.02)}


def tune(spec: ml.ManipulatorSpec, model: ml.AnalyticModel, move: ml.MinJerkMove,
         path: ml.Path, output: Path | None = None) -> JointPIDGains:
    """Grid search of the baseline's gains.

    Every grid point runs the acceptance move; candidates are taken in order of their RMS error
    (final error under 10 mm) and the first one that also runs the segment placement well
    (final error under 10 mm, |ΔP| below the supply pressure: no growing oscillation) wins.
    """
    results = []
    for kp, ki, kd in itertools.product(*GRID.values()):
        gains = JointPIDGains(kp=kp, ki=ki, kd=kd)
        row: dict[str, Any] = {"kp": kp, "ki": ki, "kd": kd}
        try:
            _, m = run_case(spec, move, MOVE_Q0, label="pid", mode="pid", task="position",
                            pid_only=gains, model=model)
            row.update(rms_mm=m.rms_error_mm, final_mm=m.final_error_mm)
        except ml.ManiplabError as exc:  # the loop went unstable: not a candidate
            row.update(rms_mm=math.inf, final_mm=math.inf, error=str(exc)[:160])
        results.append(row)
        print(f"kp={kp:g} ki={ki:g} kd={kd:g}: move {row['rms_mm']:.2f} mm RMS, "
              f"{row['final_mm']:.2f} mm final", flush=True)
    best = None
    supply = max(j.actuator.supply_pressure for j in spec.joints)
    for row in sorted((r for r in results if r["final_mm"] < 10.0), key=lambda r: r["rms_mm"]):
        gains = JointPIDGains(kp=row["kp"], ki=row["ki"], kd=row["kd"])
        try:
            _, m = run_case(spec, path, PICK_Q0, label="pid", mode="pid", task="pose",
                            pid_only=gains, model=model)
            row.update(placement_rms_mm=m.rms_error_mm, placement_final_mm=m.final_error_mm,
                       placement_peak_dP_MPa=m.peak_dP_MPa)
            ok = m.final_error_mm < 10.0 and m.peak_dP_MPa * 1e6 < supply
        except ml.ManiplabError as exc:
            row.update(placement_error=str(exc)[:160])
            ok = False
        print(f"  placement check kp={row['kp']:g} ki={row['ki']:g} kd={row['kd']:g}: "
              f"{'ok' if ok else 'rejected'}", flush=True)
        if ok:
            best = row
            break
    if best is None:
        raise ml.ManiplabError("no grid point passed; widen the grid")
    print(f"best: kp={best['kp']:g} ki={best['ki']:g} kd={best['kd']:g} "
          f"({best['rms_mm']:.2f} mm RMS, {best['final_mm']:.2f} mm final on the move)", flush=True)
    if output is not None:
        dump_json(output / "pid_tuning.json", {"grid": GRID, "results": results, "best": best})
    return JointPIDGains(kp=best["kp"], ki=best["ki"], kd=best["kd"])


def _per_joint(gain: float | tuple[float, ...] | None) -> str:
    """A gain for every joint, or one per joint, as text."""
    if isinstance(gain, tuple):
        return "[" + ", ".join(f"{g:.3g}" for g in gain) + "]"
    return f"{gain:g}"


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(__doc__.splitlines()[0], argv, tune=True)
    spec = ml.builtin_spec("erector")
    model = ml.AnalyticModel(spec)
    move = acceptance_move(model, short=args.short)
    path = placement_path(model, short=args.short)
    gains = tune(spec, model, move, path, args.output) if args.tune else resolve(spec).pid_only
    print(f"PID-only gains: kp={_per_joint(gains.kp)} /s, ki={_per_joint(gains.ki)} /s², "
          f"kd={_per_joint(gains.kd)}")
    cases = [run_case(spec, move, MOVE_Q0, label="cascade", task="position", model=model),
             run_case(spec, move, MOVE_Q0, label="PID only", mode="pid", task="position",
                      pid_only=gains, model=model)]
    report("move_pid_baseline", "Erector, Cartesian move: cascade vs PID only", cases, move,
           args.output)
    print(ratio_line(cases[1][1], cases[0][1]))
    placed = [run_case(spec, path, PICK_Q0, label="cascade", task="pose", model=model),
              run_case(spec, path, PICK_Q0, label="PID only", mode="pid", task="pose",
                       pid_only=gains, model=model)]
    report("placement_pid_baseline", "Erector segment placement: cascade vs PID only", placed,
           path, args.output)
    print(ratio_line(placed[1][1], placed[0][1]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
