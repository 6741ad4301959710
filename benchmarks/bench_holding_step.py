"""Load-holding valves at the arm's step (issue 35): arms with and without counterbalance valves
on their lifting cylinders' cap sides; for each the derived step, the open-loop run's speed
(every valve a held sine, 5 s) in real time and its deviation from the same run at a hundredth of
the step (the worst signal's largest deviation relative to its range over 1 s; stick/slip
friction left out as the derivation does), medians of REPEAT runs of CPU time, in one process.
The valves are 1.3 times the holding pressure's setting, 3:1 unless said; "compensated" gives
the sections a 15 bar local compensator, the case where a high pilot ratio makes the lowering
oscillate.

    python benchmarks/bench_holding_step.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

from bench_pump_step import at_its_step

import maniplab as ml
from maniplab.mjcf_gen import accuracy
from maniplab.mjcf_gen.accuracy import StepWarning

CRANE = Path(__file__).resolve().parents[1] / "tests" / "arms" / "knuckle_crane.yaml"


def valve(setting: float, ratio: float = 3.0) -> dict:
    return {"a": {"type": "counterbalance", "setting": setting, "pilot_ratio": ratio,
                  "nominal_flow": 1.0e-3}}


def compensated(joints: tuple[str, ...]) -> dict:
    return {f"joints.{j}.actuator.valve.compensator_margin": 1.5e6 for j in joints}


CASES = {  # arm, what, overrides
    "knuckle crane (corpus)": [
        ("without", {"joints.boom.actuator.holding": None, "joints.jib.actuator.holding": None}),
        ("220 bar, 3:1", {})],
    "patu655": [
        ("without", {}),
        ("85 bar, 3:1", {"joints.lift.actuator.holding": valve(8.5e6),
                         "joints.tilt.actuator.holding": valve(8.5e6)}),
        ("compensated, without", compensated(("lift", "tilt"))),
        ("compensated, 85 bar, 1:1", {"joints.lift.actuator.holding": valve(8.5e6, 1.0),
                                      "joints.tilt.actuator.holding": valve(8.5e6, 1.0),
                                      **compensated(("lift", "tilt"))}),
        ("compensated, 85 bar, 3:1", {"joints.lift.actuator.holding": valve(8.5e6),
                                      "joints.tilt.actuator.holding": valve(8.5e6),
                                      **compensated(("lift", "tilt"))})],
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    warnings.simplefilter("ignore", StepWarning)
    print("| arm | holding valves | derived step | open loop × real time | deviation from 1/100 |")
    print("|---|---|---|---|---|")
    for arm, cases in CASES.items():
        base = ml.resolve_spec(CRANE if arm.startswith("knuckle") else arm)
        for what, overrides in cases:
            spec = accuracy.smooth(base.with_overrides(overrides) if overrides else base)
            print(f"| {arm} | {what} | {at_its_step(spec, args.repeat)} |", flush=True)


if __name__ == "__main__":
    main()
