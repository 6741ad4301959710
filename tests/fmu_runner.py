"""Runs FMUs with FMPy, in a virtual environment that has FMPy and nothing of maniplab or MuJoCo.

Usage: ``python fmu_runner.py JOBS.json``. Each job of the JSON list is a mapping:

- ``fmu``: the .fmu file;  ``out``: the .npz to write (the outputs by name, and ``time``);
- ``dt``: the communication step, s;  ``stop``: the stop time, s;
- ``inputs``: input name -> values at ``t`` (the sample times, ``t``), or absent;
- ``outputs``: the variables to record;  ``start``: start values of parameters, or absent.

Per job it prints ``OK <fmu>`` or ``FAILED <fmu>: <exception>`` (the FMU's own log lines go to
stdout too), and ``validation: <problems>`` before simulating. It imports only FMPy and numpy.
"""

import json
import sys

import numpy as np
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu


def run(job: dict) -> None:
    print("validation:", validate_fmu(job["fmu"]), flush=True)
    table = None
    if job.get("inputs"):
        names = list(job["inputs"])
        table = np.zeros(len(job["t"]), dtype=[("time", float)] + [(n, float) for n in names])
        table["time"] = job["t"]
        for name in names:
            table[name] = job["inputs"][name]
    result = simulate_fmu(job["fmu"], stop_time=job["stop"], step_size=job["dt"],
                          output_interval=job["dt"], input=table, output=job["outputs"],
                          start_values=job.get("start", {}))
    np.savez(job["out"], time=result["time"],
             **{name: result[name].astype(float) for name in job["outputs"]})


def main() -> None:
    with open(sys.argv[1]) as file:
        jobs = json.load(file)
    for job in jobs:
        try:
            run(job)
            print("OK", job["fmu"], flush=True)
        except Exception as exc:  # noqa: BLE001 (reported per job: the test reads why it failed)
            print("FAILED", job["fmu"] + ":", exc, flush=True)


if __name__ == "__main__":
    main()
