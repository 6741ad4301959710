"""Long runs: wall time, stored MB and peak memory of erector runs of 10 s to 1 h.

Each run is ``maniplab simulate erector --input q2=step:0.2@0.1 --balanced --duration T -o FILE``
in a fresh Python process, recorded in memory or streamed to the file (``--stream``), at every
step (1 kHz) or with ``--sample-dt 0.01``. The process reports its resident memory after importing
maniplab and running 10 ms of the erector (the baseline: the model and the native library are
loaded) and its peak from then on (Linux's VmHWM, reset at that point through
``/proc/self/clear_refs``): the ratio (peak − baseline) / stored is
what recording costs per stored byte (1.0: the arrays alone).

Run: .venv/bin/python benchmarks/long_runs.py [--durations 10,60,600,3600] [--sample-dt 0.01]
(about 4 minutes with the 1-hour runs). ``bench_scaling.py`` prints the same table.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

_CHILD = """
import json, sys, time
from pathlib import Path
import maniplab as ml
from maniplab.cli import main

def status(key):  # kB in /proc/self/status
    line = next(l for l in Path("/proc/self/status").read_text().splitlines() if l.startswith(key))
    return int(line.split()[1]) * 1024 / 1e6

ml.simulate("erector", duration=0.01)
Path("/proc/self/clear_refs").write_text("5")  # the peak (VmHWM) starts again from here
base = status("VmRSS:")
start = time.perf_counter()
code = main(sys.argv[1:])
wall = time.perf_counter() - start
peak = status("VmHWM:")
print(json.dumps({"code": code, "wall_s": wall, "baseline_mb": base, "peak_mb": peak}))
"""


def run_one(duration: float, *, stream: bool, sample_dt: float | None,
            folder: Path) -> dict[str, Any]:
    """One erector run in a fresh process: its figures (see :func:`run_rows`)."""
    path = folder / "run.npz"
    argv = ["simulate", "erector", "--input", "q2=step:0.2@0.1", "--balanced",
            "--duration", f"{duration:g}", "-o", str(path)]
    argv += ["--stream"] if stream else []
    argv += ["--sample-dt", f"{sample_dt:g}"] if sample_dt else []
    done = subprocess.run([sys.executable, "-c", _CHILD, *argv], check=True,
                          capture_output=True, text=True)
    report = json.loads(done.stdout.strip().splitlines()[-1])
    if report["code"] != 0:
        raise RuntimeError(f"maniplab {' '.join(argv)} failed: {done.stderr.strip()}")
    stored = path.stat().st_size / 1e6
    path.unlink()
    return {"duration_s": duration, "mode": "stream" if stream else "memory",
            "sample_dt": sample_dt, "wall_s": report["wall_s"], "stored_mb": stored,
            "peak_rss_mb": report["peak_mb"], "baseline_mb": report["baseline_mb"],
            "ratio": (report["peak_mb"] - report["baseline_mb"]) / stored}


def run_rows(durations: tuple[float, ...] = (10, 60, 600, 3600),
             sample_dts: tuple[float | None, ...] = (None, 0.01)) -> list[dict[str, Any]]:
    """Measure every duration (s) in memory and streamed, at each recording interval (None: every
    step), each in a fresh process.

    Returns:
        One dict per run: duration_s, mode ("memory" or "stream"), sample_dt (s or None),
        wall_s (the command, saving included), stored_mb (the run file, MB), peak_rss_mb and
        baseline_mb (resident memory, MB), ratio ((peak - baseline) / stored).
    """
    rows = []
    with tempfile.TemporaryDirectory(dir=os.environ.get("MANIPLAB_BENCH_TMP")) as folder:
        for duration in durations:
            for sample_dt in sample_dts:
                for stream in (False, True):
                    rows.append(run_one(duration, stream=stream, sample_dt=sample_dt,
                                        folder=Path(folder)))
                    print(_line(rows[-1]), file=sys.stderr, flush=True)
    return rows


def markdown(rows: list[dict[str, Any]]) -> str:
    """The Markdown table of :func:`run_rows`' rows."""
    head = ("| erector run | recorded | wall, s | stored, MB | peak RSS, MB | peak − baseline, MB "
            "| (peak − baseline) / stored |\n|---|---|---|---|---|---|---|")
    return "\n".join([head, *map(_line, rows)])


def _line(row: dict[str, Any]) -> str:
    rate = "1 kHz" if row["sample_dt"] is None else f"every {row['sample_dt']:g} s"
    return (f"| {row['duration_s']:g} s, {rate} | {row['mode']} | {row['wall_s']:.1f} | "
            f"{row['stored_mb']:.1f} | {row['peak_rss_mb']:.0f} | "
            f"{row['peak_rss_mb'] - row['baseline_mb']:.0f} | {row['ratio']:.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--durations", default="10,60,600,3600", help="run durations, s")
    parser.add_argument("--sample-dt", default="0.01",
                        help="recording intervals besides every step, s, comma-separated ('' "
                             "for none)")
    args = parser.parse_args()
    durations = tuple(float(x) for x in args.durations.split(",") if x)
    sample_dts = (None, *(float(x) for x in args.sample_dt.split(",") if x))
    print(markdown(run_rows(durations, sample_dts)))


if __name__ == "__main__":
    main()
