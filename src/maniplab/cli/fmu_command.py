"""``maniplab fmu``: the arm's plant as an FMI 2.0 co-simulation FMU."""

from __future__ import annotations

import argparse

from maniplab.cli.common import output_file, positive_seconds, spec_argument


def add(sub: argparse._SubParsersAction) -> None:
    """Register the fmu sub-command."""
    fmu = sub.add_parser(
        "fmu", help="write the arm's plant as an FMU (FMI 2.0 co-simulation)",
        description="Compile the arm's plant (MuJoCo with the hydraulic actuators, friction and "
                    "limits, as maniplab simulates it) into a self-contained FMI 2.0 "
                    "co-simulation FMU for Simulink, OpenModelica, Dymola or FMPy: MuJoCo's "
                    "library is inside, the target needs no Python. Inputs u.<joint> (valve "
                    "current, force or torque); outputs q, qd, the actuator states (dP, Q, "
                    "chamber pressures) and mode per joint; parameters payload, viscous, leakage, "
                    "supply_pressure and q0.",
        epilog="Linux x86-64 only; needs a C compiler (as maniplab's plugins do).")
    spec_argument(fmu)
    fmu.add_argument("-o", "--output", type=output_file, required=True, metavar="FILE",
                     help="the .fmu file to write")
    fmu.add_argument("--step", type=positive_seconds, default=None, metavar="S",
                     help="the FMU's step, s: inputs are held over it; a communication step must "
                          "be a whole number of them (default: the step 'maniplab simulate' "
                          "takes for this arm)")
    fmu.add_argument("--integrator", default="RK4",
                     choices=("RK4", "Euler", "implicit", "implicitfast"),
                     help="MuJoCo's integrator (default RK4)")
    fmu.set_defaults(func=_cmd_fmu)


def _cmd_fmu(args: argparse.Namespace) -> int:
    import zipfile

    from maniplab.fmu import build_fmu

    path = build_fmu(args.spec, args.output, step=args.step, integrator=args.integrator)
    with zipfile.ZipFile(path) as fmu:
        size = sum(info.file_size for info in fmu.infolist())
    print(f"wrote {path} (FMI 2.0 co-simulation, {size / 1e6:.1f} MB unpacked)")
    return 0
