"""Commands on runs: simulate, sweep, compare, energy, runs (the table of a folder), crossval."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from maniplab.cli.common import (
    EXIT_MISSED,
    SAMPLE_DT_HELP,
    output_file,
    output_folder,
    plugin_option,
    positive_int,
    positive_seconds,
    set_option,
    spec_argument,
)

if TYPE_CHECKING:
    from collections.abc import Iterable, Iterator

    import numpy as np

    from maniplab.sim.run import Run
    from maniplab.sim.signals import Signal

_INPUT_HELP = ("JOINT=SIGNAL, repeatable: valve current (A) of a hydraulic joint, force (N) or "
               "torque (N·m) of a torque joint. SIGNAL is a number or step:A[@T0], "
               "impulse:AREA[,WIDTH][@T0], sine:A,FREQ_HZ[,PHASE][@T0], ramp:SLOPE[,T1][@T0], "
               "constant:V, joined by '+', e.g. q2=step:1.5@0.2 or q1=0.1+sine:0.05,2")
def add(sub: argparse._SubParsersAction) -> None:
    """Register simulate, sweep, compare, energy, runs and crossval."""
    _add_simulate(sub)
    _add_sweep(sub)
    _add_compare(sub)
    _add_energy(sub)
    _add_runs(sub)
    _add_crossval(sub)


def _run_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--input", action="append", default=[], metavar="JOINT=SIGNAL",
                        help=_INPUT_HELP)
    parser.add_argument("--duration", type=float, required=True, metavar="T",
                        help="simulated time, s")
    parser.add_argument("--dt", type=float, metavar="S",
                        help="time step, s (default: derived from the arm, 1 ms when its "
                             "actuators allow it; 'maniplab info' shows it)")
    parser.add_argument("--sample-dt", type=positive_seconds, metavar="S", help=SAMPLE_DT_HELP)
    _start_option(parser)
    parser.add_argument("--balanced", action="store_true",
                        help="start with the pressures that hold the arm against gravity at the "
                             "start pose (default: zero pressure, the arm settles on its "
                             "cylinders)")


def _start_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--start", metavar="Q1,Q2,...",
                        help="initial joint positions, rad or m (default: all 0); write "
                             "--start=-0.2,... when the first value is negative")


def _add_simulate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simulate", help="simulate an arm under input signals, store the run",
                       description="Simulate the arm from rest at q = 0 (or --start) under the given inputs "
                                   "and write the run (.npz: every signal, the spec, the "
                                   "parameters).")
    spec_argument(p)
    _run_options(p)
    set_option(p)
    p.add_argument("--stream", action="store_true",
                   help="write the samples to the run file as the run goes, in chunks, instead "
                        "of keeping them in memory (for runs too long for the memory; the file "
                        "appears complete when the run ends)")
    p.add_argument("--compress", action="store_true",
                   help="deflate the run file's arrays (about 0.4 of the size; such a file is "
                        "read whole, never memory-mapped; not with --stream)")
    p.add_argument("--supply", metavar="SIGNAL|FILE.csv",
                   help="a measured supply pressure, Pa, that every pinned cylinder's valve is "
                        "fed at instead of its pump's: a signal as for --input (e.g. 8e6+sine:"
                        "5e5,2), or a measurement CSV with columns t and supply")
    p.add_argument("--burst", action="append", default=[], metavar="JOINT:LINE@TIME",
                   help="a hose burst: the pinned cylinder's line a (cap side) or b (rod side) "
                        "opens to the atmosphere at TIME s, e.g. boom:a@1.5 (repeatable); the "
                        "run fails its health check if the load then moves more than 1 mm")
    p.add_argument("-o", "--output", type=output_file, default=Path("out/run.npz"), metavar="FILE",
                   help="the run file to write (default: out/run.npz)")
    p.epilog = ("Exit status: 0 the run is written and healthy, or has warnings (printed on "
                "stderr); 2 bad input; 3 the run is written but failed its health check (one "
                "line on stderr names the joint and the cause).")
    p.set_defaults(func=_cmd_simulate)


def _add_sweep(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sweep", help="simulate every combination of parameter values",
                       description="Simulate the grid of --vary values in parallel and write one "
                                   "run per variant into DIR; failed variants are listed.")
    spec_argument(p)
    _run_options(p)
    p.add_argument("--vary", action="append", required=True, metavar="PATH=V1,V2,...",
                   help="values of one parameter, repeatable (the grid is every combination), "
                        "e.g. end_effector.mass=3000,4000,5000")
    p.add_argument("--processes", type=positive_int, metavar="N",
                   help="local workers (default: one per core): threads when no variant needs "
                        "Python while it steps, else processes")
    p.add_argument("-o", "--output", type=output_folder, required=True, metavar="DIR",
                   help="folder for the runs")
    p.set_defaults(func=_cmd_sweep)


def _add_compare(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compare", help="overlay signals of several runs in one figure",
                       description="Plot signals of stored runs into one figure (PNG, SVG or "
                                   "PDF), one row per signal, a legend naming what differs.")
    p.add_argument("runs", metavar="RUN", nargs="+", type=Path, help="run files (.npz)")
    plugin_option(p)
    p.add_argument("--signals", default="q", metavar="S1,S2",
                   help="q, qd, dP, Q, iv, tau_act, tau_fric, mode, ee_path (default: q)")
    p.add_argument("--joints", metavar="J1,J2", help="joint columns (default: the active ones)")
    p.add_argument("-o", "--output", type=output_file, default=Path("out/compare.png"), metavar="FILE",
                   help="figure file, .png, .svg or .pdf (default: out/compare.png)")
    p.set_defaults(func=_cmd_compare)


def _add_energy(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("energy", help="where each run's hydraulic energy went, runs compared",
                       description="For each run: the energy its pump delivered through each "
                                   "pinned cylinder's valve section and where it went (meter-in, "
                                   "compensator, meter-out, leakage, relief and anti-cavitation "
                                   "losses, the tank line, the work on the piston, the oil's "
                                   "compression), as a table, and a figure comparing the runs.")
    p.add_argument("runs", metavar="RUN", nargs="+", type=Path, help="run files (.npz)")
    plugin_option(p)
    p.add_argument("-o", "--output", type=output_file, default=Path("out/energy.png"),
                   metavar="FILE", help="figure file, .png, .svg or .pdf (default: out/energy.png)")
    p.add_argument("--json", type=output_file, metavar="FILE",
                   help="also write the reports as JSON (J)")
    p.set_defaults(func=_cmd_energy)


def _add_runs(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("runs", help="table of the runs stored in a folder",
                       description="List the runs in DIR with the parameters that differ.")
    p.add_argument("folder", metavar="DIR", type=Path, help="a folder of run files")
    plugin_option(p)
    p.set_defaults(func=_cmd_runs)


def _add_crossval(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("crossval", help="cross-validate the MuJoCo plant and the analytic model",
                       description="Simulate the arm with ideal actuators (no friction, no "
                                   "limits) on the MuJoCo plant and as the analytic model "
                                   "integrated by scipy, from rest at q = 0 (or --start); print the largest "
                                   "deviation and plot both.")
    spec_argument(p)
    p.add_argument("--input", action="append", default=[], metavar="JOINT=SIGNAL",
                   help="force/torque inputs, as for simulate (default: none, the arm moves "
                        "under gravity)")
    p.add_argument("--duration", type=float, default=5.0, metavar="T",
                   help="simulated time, s (default: 5)")
    p.add_argument("--method", default="DOP853", help="scipy solver (default: DOP853)")
    _start_option(p)
    p.add_argument("-o", "--output", type=output_file, default=Path("out/crossval.png"), metavar="FILE",
                   help="figure of both trajectories (default: out/crossval.png)")
    p.set_defaults(func=_cmd_crossval)


def _inputs(texts: list[str]) -> dict[str | int, Signal]:
    """Joint name -> signal of the --input options (the terms of one joint added up), typed as
    ``simulate`` and ``sweep`` take their inputs."""
    from maniplab.sim.grammar import parse_input

    inputs: dict[str | int, Signal] = {}
    for text in texts:
        joint, signal = parse_input(text)
        inputs[joint] = inputs[joint] + signal if joint in inputs else signal
    return inputs


def _supply(text: str) -> Signal:
    """The --supply option: a signal, or a measurement CSV's ``supply`` column held at its
    samples."""
    from maniplab.identification.data import load_supply
    from maniplab.sim.grammar import parse_input

    if text.lower().endswith(".csv"):
        return load_supply(Path(text))
    return parse_input(f"supply={text}")[1]


def _initial(args: argparse.Namespace) -> dict[str, object] | None:
    """The run's initial state of --start and --balanced (None: at rest at q = 0, no pressure)."""
    initial: dict[str, object] = {}
    if args.start:
        initial["q"] = _start(args)
    if getattr(args, "balanced", False):
        initial["dP"] = "gravity"
    return initial or None


def _start(args: argparse.Namespace) -> list[float]:
    """The joint positions of --start, one per joint of the spec."""
    import maniplab as ml
    from maniplab.control.point_to_point import parse_numbers

    spec = ml.resolve_spec(args.spec)
    return list(parse_numbers(args.start, "--start", (spec.n,)))


def _cmd_simulate(args: argparse.Namespace) -> int:
    import numpy as np

    import maniplab as ml
    from maniplab.errors import ManiplabError
    from maniplab.sim.grammar import parse_assignment

    if args.stream and args.compress:
        raise ManiplabError("--compress and --stream exclude each other: a streamed run is "
                            "written in chunks as it goes")
    overrides = dict(parse_assignment(text) for text in args.set)
    spec = ml.resolve_spec(args.spec)
    start = time.perf_counter()
    run = ml.simulate(spec, inputs=_inputs(args.input), duration=args.duration, dt=args.dt,
                      overrides=overrides or None, initial=_initial(args),
                      label=args.output.stem, sample_dt=args.sample_dt,
                      stream=args.output if args.stream else None,
                      supply=_supply(args.supply) if args.supply else None,
                      bursts=args.burst)
    wall = time.perf_counter() - start
    if not args.stream:
        run.save(args.output, compress=args.compress)
    peak = max((_peak(_blocks(run, name, args.output if args.stream else None))
                for name in ("dP", "pA", "pB") if name in run.signals), default=0.0)
    print(f"wrote {args.output}: {run.spec.name}, {run.t[-1]:g} s simulated in {wall:.2f} s "
          f"({run.t[-1] / wall:.0f}x real time); final q = "
          f"{np.array2string(run.q[-1], precision=4)}; peak pressure = {peak / 1e6:.3g} MPa"
          + _energy_note(run))
    health = run.health
    for line in health.lines():
        print(f"maniplab simulate: {line}", file=sys.stderr)
    return EXIT_MISSED if health.verdict == "failed" else 0


def _energy_note(run: Run) -> str:
    """"; pump energy ... kJ, losses ... kJ" for a run with pinned cylinders (their energies'
    first and last samples: cheap for a streamed run too)."""
    if "E_pump" not in run.signals:
        return ""
    from maniplab.sim.energy import energy_report

    report = energy_report(run)
    return f"; pump energy {report.pump / 1e3:.3g} kJ, losses {report.losses / 1e3:.3g} kJ"


def _blocks(run: Run, name: str, streamed: Path | None,
            rows: int = 1 << 16) -> Iterator[np.ndarray]:
    """Signal ``name`` of ``run`` in blocks of ``rows`` samples: slices of the array in memory,
    or, for a run streamed to the file ``streamed``, read from the file (its pages are not
    mapped into the process: the run's memory stays bounded)."""
    if streamed is not None:
        from maniplab.sim import store

        yield from store.blocks(streamed, name, rows)
        return
    values = run[name]
    for start in range(0, len(values), rows):
        yield values[start:start + rows]


def _peak(blocks: Iterable[np.ndarray]) -> float:
    """The largest finite |value| of a signal given in blocks, 0 when none is finite."""
    import numpy as np

    peak = 0.0
    for block in blocks:
        values = np.abs(block)
        finite = values[np.isfinite(values)]
        if finite.size:
            peak = max(peak, float(finite.max()))
    return peak


def _cmd_sweep(args: argparse.Namespace) -> int:
    import maniplab as ml
    from maniplab.sim.grammar import parse_variation

    grid = dict(parse_variation(text) for text in args.vary)
    runs = ml.sweep(args.spec, grid, out=args.output, inputs=_inputs(args.input),
                    duration=args.duration, processes=args.processes, dt=args.dt,
                    initial=_initial(args), sample_dt=args.sample_dt)
    print(runs.table())
    print(f"\n{len(runs)} runs in {args.output}" +
          (f", {len(runs.failures)} failed" if runs.failures else ""))
    return EXIT_MISSED if runs.failures else 0


def _cmd_compare(args: argparse.Namespace) -> int:
    from maniplab.sim import Run
    from maniplab.viz.plots import compare, save_figure

    runs = [Run.load(path) for path in args.runs]
    signals = [s.strip() for s in args.signals.split(",") if s.strip()]
    joints = [j.strip() for j in args.joints.split(",")] if args.joints else None
    save_figure(compare(runs, signals=signals, joints=joints), args.output)
    print(f"wrote {args.output} ({len(runs)} runs, signals {', '.join(signals)})")
    for path, run in zip(args.runs, runs):
        print(f"{path}: {run.health.summary()}")
    return 0


def _cmd_energy(args: argparse.Namespace) -> int:
    import json

    from maniplab.atomic import atomic_path
    from maniplab.sim import Run
    from maniplab.sim.energy import energy_report
    from maniplab.viz.energy import energy_figure
    from maniplab.viz.plots import save_figure

    reports = [energy_report(Run.load(path)) for path in args.runs]
    for path, report in zip(args.runs, reports):
        print(f"{path} ({report.label}), kJ:\n{report.table()}\n")
    save_figure(energy_figure(reports), args.output)
    print(f"wrote {args.output}")
    if args.json:
        with atomic_path(args.json) as tmp:
            tmp.write_text(json.dumps([r.as_dict() for r in reports], indent=1))
        print(f"wrote {args.json}")
    return 0


def _cmd_runs(args: argparse.Namespace) -> int:
    from maniplab.sim.run import RunFileError
    from maniplab.sim.runset import RunSet

    if not args.folder.is_dir():
        raise RunFileError(f"{args.folder}: not a folder")
    runs = RunSet(args.folder)
    print(runs.table() if len(runs) else f"no runs (.npz) in {args.folder}")
    return 0


def _cmd_crossval(args: argparse.Namespace) -> int:
    import numpy as np

    from maniplab.sim.crossval import crossvalidate
    from maniplab.viz.plots import compare, save_figure

    # crossvalidate takes joint names only, which these keys are
    inputs = {str(joint): signal for joint, signal in _inputs(args.input).items()}
    result = crossvalidate(args.spec, inputs=inputs, duration=args.duration, method=args.method,
                           q0=np.asarray(_start(args)) if args.start else None)
    runs = [result.mujoco, result.analytic]
    figure = compare(runs, signals=["q"], labels=["MuJoCo plant (RK4)", f"analytic model ({args.method})"],
                     title=f"{result.mujoco.spec.name}: MuJoCo plant vs analytic model")
    save_figure(figure, args.output)
    print(f"{result.mujoco.spec.name}: largest deviation {result.max_deviation:.3g} "
          f"(rad or m) at joint {result.joint}, t = {result.time:.3g} s over "
          f"{args.duration:g} s; figure {args.output}")
    return 0
