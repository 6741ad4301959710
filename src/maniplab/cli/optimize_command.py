"""``maniplab optimize``: co-design of the arm and its controller by a study file."""

from __future__ import annotations

import argparse
from pathlib import Path

from maniplab.cli.common import output_folder, positive_int


def add(sub: argparse._SubParsersAction) -> None:
    """Register the sub-command(s) of this module."""
    p = sub.add_parser(
        "optimize", help="optimise an arm and its controller by a study file (co-design)",
        description="Search the design variables of STUDY (dotted paths as for --set: pins, "
                    "bores from the ISO 3320 catalogue, valve sizes, the controller's rate...) "
                    "for the best design by its objectives and constraints (load chart, "
                    "holding, a duty cycle's time, errors, pressures, pump energy, health, "
                    "your own metrics). Every evaluation is cached in DIR/cache by the "
                    "candidate's content: --resume, or a larger --budget, re-runs none of them. "
                    "DIR receives best.yaml (or pareto/*.yaml), evaluations.json and .csv, "
                    "summary.json, report.md and its figures.",
        epilog="Exit status: 0 a feasible design was found; 2 bad input (one line naming the "
               "study file and field); 3 no candidate met the constraints.")
    p.add_argument("study", metavar="STUDY.yaml", help="the study file")
    p.add_argument("-o", "--output", type=output_folder, default=Path("out/optimize"),
                   metavar="DIR", help="results folder (default: out/optimize)")
    p.add_argument("--budget", type=positive_int, metavar="N",
                   help="candidate evaluations (default: the study's budget)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--processes", type=positive_int, metavar="N",
                       help="local worker processes (default: the machine's cores; 1: none)")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="a Dask scheduler's address, e.g. tcp://host:8786 "
                            "(pip install 'maniplab[cluster]')")
    p.add_argument("--resume", action="store_true",
                   help="continue the study in DIR: its cached evaluations are served, not run")
    p.set_defaults(func=_cmd_optimize)


def _cmd_optimize(args: argparse.Namespace) -> int:
    import json
    import sys

    from maniplab.cli.common import EXIT_MISSED
    from maniplab.optimize import optimize

    result = optimize(args.study, out=args.output, budget=args.budget,
                      processes=args.processes, scheduler=args.scheduler, resume=args.resume)
    summary = json.loads((args.output / "summary.json").read_text())
    print(json.dumps({k: summary[k] for k in ("method", "evaluations", "computed", "cached",
                                              "feasible", "best")}, indent=2))
    if result.best is None:
        print(f"maniplab optimize: no feasible candidate among {len(result.evaluations)}; see "
              f"{args.output / 'report.md'}", file=sys.stderr)
        return EXIT_MISSED
    return 0
