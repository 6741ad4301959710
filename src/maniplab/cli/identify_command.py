"""``maniplab identify``: fit spec parameters to measurements from a real arm."""

from __future__ import annotations

import argparse
from pathlib import Path

from maniplab.cli.common import (
    output_file,
    positive_seconds,
    set_option,
    spec_argument,
    spec_with_sets,
)


def add(sub: argparse._SubParsersAction) -> None:
    """Register the sub-command of this module."""
    p = sub.add_parser(
        "identify", help="fit spec parameters to measured data (friction, leakage, payload...)",
        description="Simulate the arm under the measured inputs of each DATA file (CSV with "
                    "columns t, ctrl.<joint>, q.<joint> and optionally qd.<joint>, dP.<joint>, "
                    "pA.<joint>, pB.<joint>; or a run file) from its measured first sample, fit "
                    "the --params by bounded least squares, and print the fitted values with "
                    "95 %% confidence intervals, the residuals and what the data cannot tell "
                    "apart. Writes the fitted spec (-o) and a figure of measured against fitted "
                    "signals (--figure).")
    spec_argument(p)
    p.add_argument("data", nargs="*", type=Path, metavar="DATA",
                   help="measurement files: .csv or maniplab run files (.npz), one experiment each")
    p.add_argument("--suggest", action="store_true",
                   help="no fit: propose experiments (steps, up-down steps, sines) that make the "
                        "--params identifiable on this arm, from the outputs' sensitivities")
    p.add_argument("--duration", type=float, default=5.0, metavar="T",
                   help="with --suggest: each experiment's duration, s (default 5)")
    p.add_argument("--params", required=True, metavar="P1,P2,...",
                   help="dotted spec paths to fit, as for --set, each optionally with bounds: "
                        "joints.q2.friction.coulomb,end_effector.mass[0:8000]")
    set_option(p, "PATH=VALUE override of the spec, repeatable: a parameter's start (the fit "
                  "starts from the spec's values), e.g. end_effector.mass=4000")
    p.add_argument("--signals", metavar="S1,S2",
                   help="measured signals to fit (default: all the data has of q, qd, dP, pA, pB, "
                        "stroke)")
    p.add_argument("--loss", default="linear", choices=("linear", "soft_l1", "huber", "cauchy"),
                   help="least-squares loss: linear, or a robust one against outliers")
    p.add_argument("--dt", type=positive_seconds, metavar="S",
                   help="the plant's step for every candidate, s (default: derived for the "
                        "start's accuracy); a finer one shows how far the step moves the fit")
    p.add_argument("-o", "--output", type=output_file, default=Path("out/fitted.yaml"),
                   metavar="FILE", help="the fitted spec (default: out/fitted.yaml)")
    p.add_argument("--figure", type=output_file, default=Path("out/identify.png"),
                   metavar="FILE", help="measured against fitted signals (default: "
                                        "out/identify.png)")
    p.set_defaults(func=_cmd_identify)


def _cmd_identify(args: argparse.Namespace) -> int:
    from maniplab.atomic import write_text
    from maniplab.identification import identify, write_figure
    from maniplab.spec.yaml_io import dump_yaml

    spec = spec_with_sets(args) if args.set else args.spec
    params = [text for text in _split(args.params) if text]
    signals = [s.strip() for s in args.signals.split(",")] if args.signals else None
    if args.suggest:
        from maniplab.identification.suggest import SIGNALS, suggest

        print(suggest(spec, params, duration=args.duration,
                      signals=signals or SIGNALS).report())
        return 0
    if not args.data:
        from maniplab.identification import IdentificationError

        raise IdentificationError("no data: give one or more files (CSV or run files), or "
                                  "--suggest for experiments to make them")
    result = identify(spec, args.data, params, signals=signals, loss=args.loss, dt=args.dt)
    print(result.report())
    header = [(f"# maniplab spec '{result.spec.name}', fitted by maniplab identify to "
               f"{', '.join(str(d) for d in args.data)}:")]
    header += [f"#   {p.path} = {v:.6g} ± {s:.2g} (1 std)"
               for p, v, s in zip(result.parameters, result.values, result.std)]
    write_text(args.output, "\n".join(header) + "\n" + dump_yaml(result.spec.to_dict()))
    write_figure(result, args.figure)
    print(f"wrote {args.output} (the fitted spec) and {args.figure}")
    return 0


def _split(text: str) -> list[str]:
    """Split at commas outside brackets: ``a[0:1],b`` -> ``a[0:1]``, ``b``."""
    parts, depth, current = [], 0, ""
    for char in text:
        depth += (char == "[") - (char == "]")
        if char == "," and depth == 0:
            parts.append(current.strip())
            current = ""
        else:
            current += char
    parts.append(current.strip())
    return parts
