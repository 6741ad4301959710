"""Commands on one spec: info, export (MJCF or URDF), validate, model (the analytic model, also as MATLAB)."""

from __future__ import annotations

import argparse

from maniplab.cli.common import output_file, plugin_option, spec_argument


def add(sub: argparse._SubParsersAction) -> None:
    """Register the sub-command(s) of this module."""
    info = sub.add_parser("info", help="print a table of the arm's joints, bodies, actuators, limits",
                          description="Print a table of joints, bodies, masses, actuators and limits.")
    info.add_argument("spec", metavar="SPEC", nargs="?", help="a spec file or built-in name")
    info.add_argument("--list", action="store_true", help="list the built-in specs")
    plugin_option(info)
    info.set_defaults(func=_cmd_info)

    export = sub.add_parser("export", help="write the arm's model as MJCF or URDF",
                            description="Write the MuJoCo model (MJCF) or the URDF (links, joints, "
                                        "limits, inertias, and maniplab's actuator and friction "
                                        "parameters in an extension element), at full float "
                                        "precision.")
    spec_argument(export)
    export.add_argument("-f", "--format", choices=("mjcf", "urdf"),
                        help="output format (default: urdf for a .urdf file, else mjcf)")
    export.add_argument("-o", "--output", required=True, type=output_file, metavar="FILE",
                        help="the file to write (e.g. arm.xml, arm.urdf)")
    export.set_defaults(func=_cmd_export)

    validate = sub.add_parser("validate", help="check a spec and that MuJoCo can build it",
                              description="Validate a spec file and compile its MuJoCo model.")
    spec_argument(validate)
    validate.set_defaults(func=_cmd_validate)

    model = sub.add_parser(
        "model", help="write the arm's analytic model (LaTeX, Markdown, Python, C or MATLAB)",
        description="Write the analytic model M, C, G, Fv: readable (latex, markdown: parameters as "
                    "symbols, cse form for large arms) or as code to drop into another project "
                    "(python: math and numpy only; c: math.h only; matlab: a folder of .m "
                    "functions for MATLAB and GNU Octave).")
    spec_argument(model)
    model.add_argument("-f", "--format", choices=("latex", "markdown", "python", "c", "matlab"),
                       help="output format (default: from the file's suffix .tex, .md, .py, .c; "
                            "matlab must be given)")
    model.add_argument("-o", "--output", required=True, metavar="PATH",
                       help="the file to write; for matlab the folder to write the .m files to "
                            "(created when missing; other files in it stay)")
    model.add_argument("--symbolic", default="mass,length,payload", metavar="GROUPS",
                       help="parameter groups kept as symbols in latex/markdown, comma-separated, "
                            "from mass, length, com, inertia, payload, offset, gravity, friction; "
                            "'' for none (default: mass,length,payload)")
    model.set_defaults(func=_cmd_model)


def _cmd_info(args: argparse.Namespace) -> int:
    import maniplab as ml
    from maniplab.summary import spec_table

    if args.list or args.spec is None:
        print("built-in specs: " + ", ".join(ml.builtin_specs()))
        return 0
    print(spec_table(ml.resolve_spec(args.spec)))
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    import maniplab as ml

    fmt = args.format or ("urdf" if args.output.suffix.lower() == ".urdf" else "mjcf")
    spec = ml.resolve_spec(args.spec)
    if fmt == "urdf":
        from maniplab.urdf import write_urdf

        write_urdf(spec, args.output)
    else:
        ml.mjcf_gen.write_mjcf(spec, args.output)
    print(f"wrote {args.output} ({spec.name}, {spec.n} joints, {fmt})")
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    import maniplab as ml

    spec = ml.resolve_spec(args.spec)
    model = ml.build_model(spec)
    print(f"ok: {spec.name} is valid ({spec.n} joints, {model.nbody - 1} bodies, "
          f"{model.nu} actuators)")
    return 0


def _cmd_model(args: argparse.Namespace) -> int:
    from pathlib import Path

    import maniplab as ml
    from maniplab.atomic import check_target, write_text
    from maniplab.model.export import SUFFIXES, export_model
    from maniplab.model.parameters import GROUPS

    output = Path(args.output)
    fmt = args.format or SUFFIXES.get(output.suffix.lower())
    if fmt is None and output.is_dir():
        raise ml.ManiplabError(f"{output} is a folder: give --format matlab to write the MATLAB "
                               "functions into it, or name a .tex, .md, .py or .c file")
    if fmt is None:
        raise ml.ManiplabError(f"cannot tell the format from '{output.name}'; give --format "
                               "(latex, markdown, python, c or matlab) or a .tex, .md, .py or .c "
                               "file")
    if fmt == "matlab":
        from maniplab.model.matlab import export_matlab, matlab_prefix

        if output.exists() and not output.is_dir():
            raise ml.ManiplabError(f"{output}: exists and is not a folder (-o names the folder "
                                   "of the MATLAB functions)")
        spec = ml.resolve_spec(args.spec)
        files = export_matlab(spec, output)
        print(f"wrote {len(files)} files {matlab_prefix(spec.name)}_* to {output} ({spec.name}, "
              f"{spec.n} joints, matlab)")
        return 0
    check_target(output)  # a folder or device named as the file: refused before any work
    symbolic = [g.strip() for g in args.symbolic.split(",") if g.strip()]
    unknown = [g for g in symbolic if g not in GROUPS]
    if unknown:
        raise ml.ManiplabError(f"unknown parameter group '{unknown[0]}' in --symbolic; expected "
                               f"some of {', '.join(GROUPS)}")
    spec = ml.resolve_spec(args.spec)
    text = export_model(spec, fmt, symbolic)
    write_text(output, text)
    print(f"wrote {output} ({spec.name}, {spec.n} joints, {fmt})")
    return 0
