"""Run maniplab's C code under AddressSanitizer and UBSan: ``make sanitize``.

Builds the native library (and, in the FMU target, an FMU's C functions) with the sanitizers
(``MANIPLAB_NATIVE_SANITIZE=1``: a cache folder of its own), then runs, each in a sanitized child
process: the native tests (tests/test_plant_native.py, test_native_plugins.py,
test_valve_native.py, test_cascade_native.py) and the fuzz targets of tests/sanitize/ (fuzz_plant,
fuzz_plugins, fuzz_cascade, fuzz_fmu). Any sanitizer report fails the run.

    python tests/sanitize/run.py            # everything, 5x each target's default examples
    python tests/sanitize/run.py --quick    # the subset make test runs (a few examples each)
    python tests/sanitize/run.py --scale 20 fuzz_plant   # one target, more examples

Prints one line per part (passed, time) and exits 0 when all are clean.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from sanitized import HERE, ROOT, report_of, run_child

NATIVE_TESTS = ["tests/test_plant_native.py", "tests/test_native_plugins.py",
                "tests/test_valve_native.py", "tests/test_cascade_native.py"]
TARGETS = ["fuzz_plant", "fuzz_plugins", "fuzz_cascade", "fuzz_fmu"]
QUICK = ["tests/sanitize/fuzz_plant.py::test_construction",
         "tests/sanitize/fuzz_plant.py::test_stepping", "tests/sanitize/fuzz_plant.py::test_runs",
         "tests/sanitize/fuzz_plugins.py",
         "tests/sanitize/fuzz_cascade.py::test_samples",
         "tests/sanitize/fuzz_cascade.py::test_native_control",
         "tests/sanitize/fuzz_cascade.py::test_threads_separate_controllers",
         "tests/sanitize/fuzz_fmu.py"]
"""The subset of tests/test_sanitize.py (make test): every target but the known defects'
children and the closed loops."""

PYTEST = ["-m", "pytest", "-q", "-p", "no:cacheprovider",
          "-W", "ignore::pytest.PytestAssertRewriteWarning"]


def part(name: str, args: list[str], scale: float) -> bool:
    os.environ["MANIPLAB_FUZZ_SCALE"] = repr(scale)
    started = time.monotonic()
    proc = run_child([*PYTEST, *args], timeout=3600)
    took = time.monotonic() - started
    report = report_of(proc)
    summary = (proc.stdout.strip().splitlines() or ["(no output)"])[-1]
    ok = proc.returncode == 0 and report is None
    print(f"{name:<14} {'clean' if ok else 'FAILED'}  {took:6.1f} s  {summary}", flush=True)
    if not ok:
        print(report or (proc.stdout[-4000:] + proc.stderr[-4000:]), flush=True)
    return ok


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("targets", nargs="*", help=f"parts to run (default all): native, "
                        f"{', '.join(TARGETS)}")
    parser.add_argument("--quick", action="store_true", help="the short subset of make test")
    parser.add_argument("--scale", type=float, default=None,
                        help="examples per target, times its default (5; --quick: 0.5)")
    args = parser.parse_args()
    os.chdir(ROOT)
    if args.quick:
        return 0 if part("quick", QUICK, args.scale or 0.5) else 1
    scale = args.scale or 5.0
    parts = args.targets or ["native", *TARGETS]
    ok = True
    for name in parts:
        if name == "native":
            ok &= part(name, NATIVE_TESTS, scale)
        elif name in TARGETS:
            ok &= part(name, [str(HERE / f"{name}.py"), "--hypothesis-show-statistics"], scale)
        else:
            print(f"unknown part {name!r}; expected native or {', '.join(TARGETS)}")
            return 2
    print("sanitizers: clean" if ok else "sanitizers: FAILED", flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
