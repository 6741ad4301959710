"""Start-up time of the command and the package: medians of 10 fresh processes each, beside the
bare interpreter's start in the same run (the peer: nothing can start faster).

    python benchmarks/bench_startup.py
"""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import time

RUNS = 10
CASES = {
    "python -c pass (the interpreter alone)": [sys.executable, "-c", "pass"],
    "python -c 'import maniplab'": [sys.executable, "-c", "import maniplab"],
    "maniplab --version": [shutil.which("maniplab") or "maniplab", "--version"],
    "maniplab --help": [shutil.which("maniplab") or "maniplab", "--help"],
    "maniplab simulate --help": [shutil.which("maniplab") or "maniplab", "simulate", "--help"],
    "python -c 'import maniplab; maniplab.simulate' (loads MuJoCo, the plant)":
        [sys.executable, "-c", "import maniplab; maniplab.simulate"],
}


def median_start(argv: list[str]) -> float:
    times = []
    for _ in range(RUNS):
        start = time.perf_counter()
        subprocess.run(argv, stdout=subprocess.DEVNULL, check=True)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    results = {name: median_start(argv) for name, argv in CASES.items()}
    bare = results["python -c pass (the interpreter alone)"]
    print(f"medians of {RUNS} process starts (wall time)")
    print("| what | s | × the bare interpreter |")
    print("|---|---|---|")
    for name, t in results.items():
        print(f"| {name} | {t:.3f} | {t / bare:.1f} |")


if __name__ == "__main__":
    main()
