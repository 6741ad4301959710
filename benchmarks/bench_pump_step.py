"""Pumps at the arm's step (issue 34): patu655 and the excavator with their own supplies, a
shared constant-pressure pump, a load-sensing pump (quasi-static) and one with a 30 ms response;
for each the derived step, the open-loop run's speed (every valve a held sine, 5 s) in real time
and its deviation from the same run at a hundredth of the step (the worst signal's largest
deviation relative to its range over 1 s; stick/slip friction left out as the derivation does),
medians of REPEAT runs of CPU time, in one process. The pump's flow is ample (the pump never
runs short: a starved pump makes its cylinders cavitate, a separate matter, see the benchmarks
page).

    python benchmarks/bench_pump_step.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import warnings

from bench_stiff_step import ACCURACY_WINDOW, OPEN_LOOP, cpu, deviation, open_loop

import maniplab as ml
from maniplab.mjcf_gen import accuracy
from maniplab.mjcf_gen.accuracy import StepWarning

PUMPS = {
    "own supplies": None,
    "shared constant pressure": {"max_flow": 1.0},
    "load-sensing": {"max_flow": 1.0, "ls_margin": 2.0e6},
    "load-sensing, 30 ms response": {"max_flow": 1.0, "ls_margin": 2.0e6, "response": 0.03},
}


def with_pump(arm: str, pump: dict | None) -> ml.ManipulatorSpec:
    """The arm (stick/slip friction left out) with this pump at its cylinders' supply pressure."""
    spec = accuracy.smooth(ml.resolve_spec(arm))
    if pump is None:
        return spec
    pressure = next(j.actuator.supply_pressure for j in spec.joints
                    if getattr(j.actuator, "cylinder", None))
    data = spec.to_dict()
    data["supply"] = {"pressure": pressure, **pump}
    return ml.ManipulatorSpec.from_dict(data)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    warnings.simplefilter("ignore", StepWarning)
    print("| arm | pump | derived step | open loop × real time | deviation from 1/100 |")
    print("|---|---|---|---|---|")
    for arm in ("patu655", "excavator"):
        for name, pump in PUMPS.items():
            print(f"| {arm} | {name} | {at_its_step(with_pump(arm, pump), args.repeat)} |",
                  flush=True)


def at_its_step(spec: ml.ManipulatorSpec, repeat: int) -> str:
    """"derived step | open loop × real time | deviation from 1/100": the arm's derived step,
    its open-loop run's speed there (median CPU time of ``repeat``) and the run's deviation from
    the same at a hundredth of the step (the worst signal's)."""
    plant = ml.Plant(spec)
    dt = plant.dt
    names = ["q", "qd", *plant.state_names]
    error, signal = deviation(open_loop(spec, dt, dt, ACCURACY_WINDOW),
                              open_loop(spec, dt / 100.0, dt, ACCURACY_WINDOW), names)
    seconds = cpu(repeat, open_loop, spec, dt, dt, OPEN_LOOP)
    return f"{dt * 1e3:g} ms | {OPEN_LOOP / seconds:.0f}× | {error:.1e} ({signal})"


if __name__ == "__main__":
    main()
