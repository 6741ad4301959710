"""``maniplab tune``: the controller's gains and rate derived from the arm, with the reasoning."""

from __future__ import annotations

import argparse
import dataclasses

from maniplab.cli.common import output_file, set_option, spec_argument, spec_with_sets


def add(sub: argparse._SubParsersAction) -> None:
    """Register the sub-command of this module."""
    tune = sub.add_parser(
        "tune", help="print the controller's gains and rate derived from the arm",
        description="Derive the cascade controller's gains and rate (and the PID-only "
                    "baseline's) from the arm and its actuators: the pressure loop from the "
                    "valves' lag, the outer loop a factor 3 below it, the rate from the fastest "
                    "loop, the baseline from the arm's slowest hydraulic spring mode. Prints a "
                    "control: section, one comment line of reasoning per gain. Gains written in "
                    "the spec's control: section win over derived ones.")
    spec_argument(tune)
    set_option(tune, "PATH=VALUE override of the spec, repeatable: the gains derived for that "
                     "arm, e.g. end_effector.mass=4000")
    tune.add_argument("-o", "--output", type=output_file, metavar="FILE",
                      help="write a copy of the spec with the control: section filled in "
                           "(gains already in the spec kept)")
    tune.set_defaults(func=_cmd_tune)


def _cmd_tune(args: argparse.Namespace) -> int:
    from maniplab.control.tuning import derive, resolve
    from maniplab.schema import plain
    from maniplab.spec.yaml_io import dump_yaml

    spec = spec_with_sets(args)
    reasons = derive(spec).reasons
    control = resolve(spec)
    given = spec.control is not None
    print(f"# {spec.name}: controller settings derived from the arm"
          + (" (gains in its control: section kept)" if given else ""))
    for key, reason in reasons.items():
        print(f"# {key}: {reason}")
    print(dump_yaml({"control": plain(dataclasses.asdict(control))}), end="")
    if args.output is not None:
        dataclasses.replace(spec, control=control).dump(args.output)
        print(f"# written to {args.output}")
    return 0
