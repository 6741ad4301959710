"""Speed of the plant: the erector's real-time factor; hybrid friction vs LuGre, matched accuracy.

Run: ``python benchmarks/bench_plant.py`` (about a minute; ``--quick`` takes fewer repeats).
Prints Markdown tables for the benchmark page. Times are medians of repeated runs, as CPU time of
this process (``time.process_time``) and wall time; on a shared machine the CPU time is the
steadier figure, and the ratios (measured in one run) are what to compare.

1. **Erector, 10 s open loop** (6 hydraulic joints, hybrid friction, limits; valve steps, sines
   and ramps that make joints stick, slip and reach limits): the plant's real-time factor against
   MuJoCo's RK4 ``mj_step`` of the plant's own model (the cylinders' engine plugins, MuJoCo's
   limits and dry friction off, as in the plant) and of the exported MJCF (with MuJoCo's soft
   limits and ``frictionloss``).
2. **Stick-slip** (Canudas de Wit 1995: 1 kg block pulled through a spring k = 2 N/m at
   0.1 m/s): for each friction model, the largest step (from a ladder) whose position stays within
   a tolerance (``TOLERANCES``) of that model's own reference over 20 s (LuGre: Radau; hybrid: an
   event-driven solve_ivp of the hybrid automaton), and the time the run takes at that step. The
   spring is MuJoCo joint stiffness plus a ramped force, so the friction is what differs. LuGre is
   maniplab's engine plugin ``maniplab.lugre`` (z advanced exactly after each step).
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable

import mujoco
import numpy as np
from scipy.integrate import solve_ivp

import maniplab as ml

SIGNALS = ml.signals
ERECTOR_INPUTS = {
    "q1": SIGNALS.step(0.3, t0=0.5) - SIGNALS.step(0.6, t0=5.0),
    "q2": SIGNALS.sine(0.4, 0.25),
    "q3": SIGNALS.step(-0.3, t0=2.0),
    "q4": SIGNALS.step(0.5, t0=1.0) - SIGNALS.step(1.0, t0=6.0),
    "q5": SIGNALS.sine(0.5, 0.5, t0=3.0),
    "q6": SIGNALS.ramp(0.1, t0=1.0, t1=6.0),
}

# the stick-slip case (Canudas de Wit et al. 1995, Table I)
SIGMA0, SIGMA1, SIGMA2 = 1e5, math.sqrt(1e5), 0.4
FC, FS, VS, MASS, K, VP, T_END = 1.0, 1.5, 1e-3, 1.0, 2.0, 0.1, 20.0
STICK_VELOCITY = 1e-3
TOLERANCES = (5e-3, 1e-3)  # m, over a travel of about 1.3 m
LADDER = (2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5)


def timed(fn, repeats: int) -> tuple[float, float]:
    """Median (CPU, wall) seconds of ``fn()`` over ``repeats`` runs."""
    cpu, wall = [], []
    for _ in range(repeats):
        c, w = time.process_time(), time.perf_counter()
        fn()
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - w)
    return statistics.median(cpu), statistics.median(wall)


# --- 1. erector ----------------------------------------------------------------------------------

def erector(repeats: int) -> list[str]:
    rows = []
    plant = ml.Plant("erector")
    ctrl = np.zeros(6)

    def bare(model: mujoco.MjModel) -> Callable[[], None]:
        data = mujoco.MjData(model)
        data.ctrl[:] = ctrl
        return lambda: [mujoco.mj_step(model, data) for _ in range(10_000)]

    floor = timed(bare(plant.model), repeats)
    rows.append(("MuJoCo mj_step of the plant's model alone (RK4, 10,000 steps)", floor,
                 "the floor"))
    exported = timed(bare(ml.build_model("erector")), repeats)
    rows.append(("MuJoCo mj_step of the exported MJCF (soft limits, frictionloss)", exported,
                 f"{exported[0] / floor[0]:.2f}x the floor"))
    plant.balance_pressures()
    start = plant.save()

    def run() -> ml.Run:
        plant.restore(start)
        return ml.simulate(plant, inputs=ERECTOR_INPUTS, duration=10.0)

    result = run()
    modes = [sorted({ml.friction.FrictionMode(m).name for m in result["mode"][:, j]})
             for j in range(6)]
    t = timed(run, repeats)
    rows.append(("plant, ml.simulate (10 s simulated)", t,
                 (f"{10.0 / t[0]:.0f}x real time (CPU), {10.0 / t[1]:.0f}x (wall); "
                  f"{t[0] / floor[0]:.2f}x the floor")))
    build = timed(lambda: ml.simulate("erector", inputs=ERECTOR_INPUTS, duration=10.0,
                                      initial={"dP": "gravity"}), repeats)
    rows.append(("ml.simulate end to end (plant built, 10 s)", build,
                 f"{10.0 / build[0]:.0f}x real time (CPU), {10.0 / build[1]:.0f}x (wall)"))
    lines = ["| what | CPU | wall | note |", "|---|---|---|---|"]
    lines += [f"| {name} | {c:.3f} s | {w:.3f} s | {note} |" for name, (c, w), note in rows]
    lines.append("")
    lines.append("modes visited per joint: " + "; ".join(
        f"q{j + 1} {'/'.join(m)}" for j, m in enumerate(modes)))
    return lines


# --- 2. stick-slip -------------------------------------------------------------------------------

def block(model: str) -> ml.ManipulatorSpec:
    return ml.ManipulatorSpec.from_dict({
        "name": "block",
        "joints": [{"name": "x", "type": "P", "axis": "x", "body": {"mass": MASS},
                    "friction": {"model": model, "coulomb": FC, "static": FS - FC,
                                 "viscous": SIGMA2, "stribeck_velocity": VS,
                                 "stick_velocity": STICK_VELOCITY, "sigma0": SIGMA0,
                                 "sigma1": SIGMA1}}],
    })


def g(v: float) -> float:
    return FC + (FS - FC) * math.exp(-((v / VS) ** 2))


def lugre_reference():
    def rhs(t: float, y: np.ndarray) -> list[float]:
        x, v, z = y
        zd = v - SIGMA0 * abs(v) * z / g(v)
        return [v, (K * (VP * t - x) - SIGMA0 * z - SIGMA1 * zd - SIGMA2 * v) / MASS, zd]

    sol = solve_ivp(rhs, (0.0, T_END), [0.0, 0.0, 0.0], method="Radau", rtol=1e-10,
                    atol=1e-12, dense_output=True, max_step=1e-2).sol
    return lambda t: sol(t)[0]


def hybrid_reference():
    """The hybrid automaton integrated exactly: stuck until the spring force reaches Fc + Fs,
    then slipping (Coulomb + Stribeck + viscous) until the velocity falls below the stick
    velocity, located by solve_ivp's event detection."""
    pieces: list[tuple[float, float, object]] = []  # (start, end, x(t))
    t, x = 0.0, 0.0
    while t < T_END:
        release = (FC + (FS - FC)) / (K * VP) + x / VP  # k (VP t - x) = Fc + Fs
        if release > t:
            pieces.append((t, min(release, T_END), lambda s, x=x: np.full_like(s, x)))
            t = release
        if t >= T_END:
            break

        def rhs(s: float, y: np.ndarray) -> list[float]:
            pos, v = y
            friction = (FC + (FS - FC) * math.exp(-((v / VS) ** 2))) + SIGMA2 * v
            return [v, (K * (VP * s - pos) - friction) / MASS]

        def slow(s: float, y: np.ndarray) -> float:
            return y[1] - STICK_VELOCITY

        slow.terminal, slow.direction = True, -1
        sol = solve_ivp(rhs, (t, T_END), [x, 0.0], method="Radau", rtol=1e-11, atol=1e-13,
                        events=slow, dense_output=True)
        pieces.append((t, sol.t[-1], lambda s, f=sol.sol: f(s)[0]))
        t, x = sol.t[-1], sol.y[0, -1]

    def position(times: np.ndarray) -> np.ndarray:
        out = np.empty_like(times)
        for start, end, f in pieces:
            inside = (times >= start) & (times <= end)
            out[inside] = f(times[inside])
        return out

    return position


def stick_slip_run(model: str, dt: float) -> Callable[[], ml.Run]:
    plant = ml.Plant(block(model), dt=dt)
    # the spring: -k x as MuJoCo's joint stiffness, +k VP t as the input; set on the model the
    # plant steps (its working copy: ``plant.model`` is the constant description of the arm)
    plant._model.jnt_stiffness[0] = K
    start = plant.save()

    def run() -> ml.Run:
        plant.restore(start)
        return ml.simulate(plant, inputs={"x": SIGNALS.ramp(K * VP)}, duration=T_END,
                           sample_dt=1e-2)

    return run


def errors(model: str, reference, ladder, target: float) -> dict[float, float]:
    """Max position error of the run at each dt of the ladder (inf when unstable), going down
    the ladder until the error is within ``target``."""
    out: dict[float, float] = {}
    for dt in ladder:
        try:
            result = stick_slip_run(model, dt)()
            out[dt] = float(np.max(np.abs(result.q[:, 0] - reference(result.t))))
        except ml.InstabilityError:
            out[dt] = math.inf
        if out[dt] <= target:
            break
    return out


def stick_slip(repeats: int) -> list[str]:
    lugre, hybrid = lugre_reference(), hybrid_reference()
    cases = [("hybrid automaton", "hybrid", hybrid, LADDER),
             ("LuGre (engine plugin, exact bristle update)", "lugre", lugre, LADDER)]
    found = {name: errors(model, ref, ladder, min(TOLERANCES))
             for name, model, ref, ladder in cases}
    lines = [("| tolerance | friction model | largest dt within it | error | CPU | wall "
              "| CPU / hybrid's |"), "|---|---|---|---|---|---|---|"]
    timings: dict[tuple[str, float], tuple[float, float]] = {}
    for tolerance in TOLERANCES:
        base = None
        for name, model, _, _ in cases:
            good = [dt for dt, error in found[name].items() if error <= tolerance]
            if not good:
                lines.append(f"| {tolerance * 1e3:g} mm | {name} | none down to "
                             f"{min(found[name]):g} s | | | | |")
                continue
            dt = max(good)
            if (name, dt) not in timings:
                timings[name, dt] = timed(stick_slip_run(model, dt), repeats)
            cpu, wall = timings[name, dt]
            base = base or cpu
            lines.append(f"| {tolerance * 1e3:g} mm | {name} | {dt:g} s | "
                         f"{found[name][dt] * 1e3:.2f} mm | {cpu:.3f} s | {wall:.3f} s | "
                         f"{cpu / base:.1f}x |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="one repeat of each timing")
    args = parser.parse_args()
    if args.quick:
        args.repeats = 1
    print(f"maniplab {ml.__version__}, MuJoCo {mujoco.__version__}\n")
    print("### Erector, 10 s open loop\n")
    print("\n".join(erector(args.repeats)))
    print("\n### Stick-slip, hybrid vs LuGre at matched accuracy\n")
    print("\n".join(stick_slip(args.repeats)))


if __name__ == "__main__":
    main()
