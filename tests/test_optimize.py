"""maniplab optimize: answers checked against references computed here, independently.

- the pin placement that maximises the smallest holding torque of a boom's lift cylinder over its
  range, against a dense grid of the closed-form geometry (Rodrigues' rotation of the pin, the
  cylinder's line of action, the stroke's feasibility), found within 1 % in a stated budget;
- the smallest ISO 3320 bore whose load chart meets required payloads, against enumeration;
- a resumed, an extended and an interrupted study re-run nothing already evaluated (counted);
- local processes and a Dask cluster give the same study;
- bad study files: one line naming file and field, exit status 2.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from commandline import run_cli

import maniplab as ml
from maniplab.optimize import StudyError, optimize
from maniplab.optimize.catalogue import ISO3320_BORE_MM

PIVOT = np.array([0.3, 0.0, -0.8])
"""The lift cylinder's parent pin, m (base axes, from the joint)."""
LIMITS = (-0.6, 0.6)
BORE, ROD, RELIEF, TANK = 0.1, 0.056, 22e6, 0.2e6
MIN_LENGTH, STROKE = 0.3, 2.0

BOOM = {
    "name": "boom1",
    "gravity": [0.0, 0.0, -9.81],
    "joints": [{
        "name": "lift", "type": "R", "axis": "y", "limits": list(LIMITS),
        "body": {"length": 3.0, "direction": [1, 0, 0], "mass": 400.0},
        "actuator": {
            "type": "hydraulic",
            "cylinder": {"pins": {"parent": PIVOT.tolist(), "child": [1.0, 0.0, 0.0]},
                         "bore": BORE, "rod": ROD, "min_length": MIN_LENGTH, "stroke": STROKE,
                         "dead_volumes": [0.0005, 0.0005]},
            "valve": {"nominal_flow": 0.001, "nominal_pressure_drop": 3.5e6, "tau": 0.01},
            "supply_pressure": 20e6, "tank_pressure": TANK, "relief_pressure": RELIEF,
            "bulk_modulus": 1e9, "leakage": 1e-13}}],
    "end_effector": {"mass": 100.0},
}

PIN_X, PIN_Z = (0.4, 1.6), (-0.5, 0.5)
PIN_BUDGET = 300
"""Differential evolution's evaluations for the pin problem (30 per generation)."""


def write(folder: Path, name: str, data: Any) -> Path:
    path = folder / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def boom(folder: Path) -> Path:
    return write(folder, "boom1.yaml", BOOM)


def pin_study(folder: Path, budget: int = PIN_BUDGET, **more: Any) -> Path:
    boom(folder)
    return write(folder, "pins.yaml", {
        "spec": "boom1.yaml", "seed": 3, "budget": budget,
        "variables": [
            {"path": "joints.lift.actuator.cylinder.pins.child[0]", "low": PIN_X[0],
             "high": PIN_X[1]},
            {"path": "joints.lift.actuator.cylinder.pins.child[2]", "low": PIN_Z[0],
             "high": PIN_Z[1]}],
        "objectives": [{"metric": "holding:lift", "sense": "max"}], **more})


def smallest_holding(cx: np.ndarray, cz: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The smallest torque the lift cylinder holds both ways over the poses q, N·m, for child
    pins (cx, 0, cz), by the geometry alone; -inf where the spec must refuse the pins (the
    cylinder's length leaves [min_length, min_length + stroke], or its line crosses the joint)."""
    c, s = np.cos(q), np.sin(q)
    x = cx[..., None] * c + cz[..., None] * s  # the pin turned about +y by q
    z = -cx[..., None] * s + cz[..., None] * c
    dx, dz = x - PIVOT[0], z - PIVOT[2]
    length = np.hypot(dx, dz)
    arm = (z * dx - x * dz) / length  # (pin × unit line of action) · y
    ok = ((length.min(-1) >= MIN_LENGTH - 1e-9) & (length.max(-1) <= MIN_LENGTH + STROKE + 1e-9)
          & ((arm.min(-1) > 0) | (arm.max(-1) < 0)))
    cap = math.pi / 4 * BORE**2
    annulus = cap - math.pi / 4 * ROD**2
    weakest = RELIEF * annulus - TANK * cap  # pulling on the annulus, the cap side at tank
    return np.where(ok, weakest * np.abs(arm).min(-1), -np.inf)


def test_the_pin_placement_is_found_within_one_percent_of_a_dense_grid(tmp_path: Path) -> None:
    result = optimize(pin_study(tmp_path), out=tmp_path / "out", processes=1)
    q = np.linspace(*LIMITS, 121)
    cx, cz = np.meshgrid(np.linspace(*PIN_X, 301), np.linspace(*PIN_Z, 251), indexing="ij")
    grid = smallest_holding(cx, cz, q)
    optimum = float(grid.max())
    assert result.method == "differential_evolution" and len(result.evaluations) == PIN_BUDGET
    assert result.best is not None
    found = result.best["metrics"]["holding:lift"]
    assert found >= 0.99 * optimum, (found, optimum)
    # the reported objective is the geometry's at the pins written in best.yaml
    best = ml.load_spec(tmp_path / "out" / "best.yaml")
    child = best.joints[0].actuator.cylinder.pins.child
    again = float(smallest_holding(np.array(child[0]), np.array(child[2]), q))
    assert found == pytest.approx(again, rel=1e-6)
    assert found <= optimum * 1.01  # no better than the grid's optimum, up to its spacing
    # candidates the spec refused are infeasible with their reason, as the geometry says
    refused = [r for r in result.evaluations if r["reason"]]
    assert refused and all("stroke" in r["reason"] or "dead point" in r["reason"]
                           or "moment arm" in r["reason"] for r in refused), refused[0]["reason"]
    for r in refused[:5]:
        x, z = r["values"]
        assert smallest_holding(np.array(x), np.array(z), q) == -np.inf
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["computed"] == result.computed and summary["best"]["metrics"][
        "holding:lift"] == pytest.approx(found)
    for name in ("convergence.png", "sensitivity.png", "report.md", "evaluations.csv"):
        assert (tmp_path / "out" / name).stat().st_size > 0


REQUIRED = {"payload@1.0": 6000.0, "payload@2.5": 4500.0}
"""Payloads (kg) the catalogue problem's load chart must hold at reaches of at least 1 and 2.5 m."""


def bore_study(folder: Path, **more: Any) -> Path:
    boom(folder)
    return write(folder, "bores.yaml", {
        "spec": "boom1.yaml", "seed": 1, "budget": 40,
        "variables": [{"path": "joints.lift.actuator.cylinder.bore", "catalogue": "iso3320-bore"}],
        "statics": {"points": 9},
        "objectives": [{"metric": "param:joints.lift.actuator.cylinder.bore", "sense": "min"}],
        "constraints": [{"metric": m, "min": kg} for m, kg in REQUIRED.items()], **more})


def test_the_smallest_standard_bore_meeting_the_payloads_is_the_enumerated_one(
        tmp_path: Path) -> None:
    base = ml.load_spec(boom(tmp_path))
    expected = None
    for bore in (mm / 1000 for mm in ISO3320_BORE_MM):
        try:
            spec = base.with_overrides({"joints.lift.actuator.cylinder.bore": bore})
        except ml.SpecError:
            continue  # a rod as wide as the bore
        chart = ml.load_chart(spec, points=9)
        held = {f"payload@{r}": max((m for m, x in zip(chart.payload, chart.reach)
                                     if x >= float(r) - 1e-9), default=0.0)
                for r in ("1.0", "2.5")}
        if all(held[k] >= kg for k, kg in REQUIRED.items()):
            expected = bore
            break
    assert expected is not None and ROD < expected < ISO3320_BORE_MM[-1] / 1000
    result = optimize(bore_study(tmp_path), out=tmp_path / "out", processes=1)
    assert result.method == "grid" and result.best is not None
    assert result.best["values"] == [pytest.approx(expected)]
    assert ml.load_spec(tmp_path / "out" / "best.yaml").joints[0].actuator.cylinder.bore == \
        pytest.approx(expected)
    narrow = [r for r in result.evaluations if r["values"][0] <= ROD]
    assert narrow and all(r["reason"] and "rod" in r["reason"] for r in narrow)
    smaller = [r for r in result.evaluations if ROD < r["values"][0] < expected]
    assert smaller and not any(r["feasible"] for r in smaller)


def test_a_resumed_study_computes_nothing_and_an_extended_one_only_the_new(tmp_path: Path) -> None:
    first = optimize(pin_study(tmp_path, budget=60), out=tmp_path / "out", processes=1)
    # the search starts from the base design, evaluated once as the baseline (served again)
    assert first.evaluations[0]["values"] == first.baseline["values"] == [1.0, 0.0]
    assert first.cached == 1 and first.computed == len({r["key"] for r in first.evaluations}) + 4
    again = optimize(pin_study(tmp_path, budget=60), out=tmp_path / "out", processes=1,
                     resume=True)
    assert again.computed == 0
    assert [r["values"] for r in again.evaluations] == [r["values"] for r in first.evaluations]
    assert again.best == {**first.best, "source": "cache"}  # type: ignore[dict-item]
    more = optimize(pin_study(tmp_path, budget=120), out=tmp_path / "out", processes=1,
                    resume=True)
    assert [r["values"] for r in more.evaluations[:60]] == [r["values"]
                                                            for r in first.evaluations]
    assert all(r["source"] == "cache" for r in more.evaluations[:60])
    assert more.computed <= 60 + 2 * 2  # the new generations and the new sensitivity only
    with pytest.raises(ml.ManiplabError, match="--resume"):
        optimize(pin_study(tmp_path, budget=60), out=tmp_path / "out", processes=1)


def test_an_interrupted_study_resumes_where_it_stopped(tmp_path: Path) -> None:
    counter = tmp_path / "count.txt"
    (tmp_path / "ticks.py").write_text(
        "from pathlib import Path\n"
        f"COUNT = Path({str(counter)!r})\n"
        "def tick(spec, runs):\n"
        "    n = int(COUNT.read_text()) + 1 if COUNT.exists() else 1\n"
        "    COUNT.write_text(str(n))\n"
        "    if n == 25:\n"
        "        raise KeyboardInterrupt\n"
        "    return 0.0\n")
    study = pin_study(tmp_path, budget=60, plugins={"tick": f"{tmp_path / 'ticks.py'}:tick"},
                      constraints=[{"metric": "tick", "max": 1.0}])
    with pytest.raises(KeyboardInterrupt):
        optimize(study, out=tmp_path / "out", processes=1)
    stored = len(list((tmp_path / "out" / "cache").glob("*.json")))
    assert stored >= 24  # the 24 that called the plugin, and those the spec refused
    resumed = optimize(study, out=tmp_path / "out", processes=1, resume=True)
    total = len(list((tmp_path / "out" / "cache").glob("*.json")))
    assert resumed.computed == total - stored and resumed.cached >= stored
    assert optimize(study, out=tmp_path / "out", processes=1, resume=True).computed == 0


def mixed_study(folder: Path) -> Path:
    """Two objectives, a catalogue and a continuous variable: NSGA-II."""
    boom(folder)
    return write(folder, "mixed.yaml", {
        "spec": "boom1.yaml", "seed": 5, "budget": 24, "population": 8,
        "variables": [
            {"path": "joints.lift.actuator.cylinder.bore", "choices": [0.08, 0.1, 0.125]},
            {"path": "joints.lift.actuator.cylinder.pins.child[0]", "low": 0.8, "high": 1.4}],
        "statics": {"points": 5},
        "objectives": [{"metric": "payload_min", "sense": "max"},
                       {"metric": "param:joints.lift.actuator.cylinder.bore", "sense": "min"}]})


def test_a_dask_cluster_gives_the_same_study_as_local_processes(tmp_path: Path) -> None:
    from dask.distributed import LocalCluster

    local = optimize(mixed_study(tmp_path), out=tmp_path / "local", processes=2, report=False)
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                      dashboard_address=None) as cluster:  # reached by its address (--scheduler)
        dask = optimize(mixed_study(tmp_path), out=tmp_path / "dask",
                        scheduler=cluster.scheduler_address, report=False)
    assert local.method == dask.method == "nsga2"
    strip = [[(r["values"], r["metrics"], r["feasible"]) for r in x.evaluations]
             for x in (local, dask)]
    assert strip[0] == strip[1]
    # the Pareto set: no feasible evaluation dominates a member, every other is dominated
    points = {r["key"]: (-r["metrics"]["payload_min"], r["values"][0])
              for r in local.evaluations if r["feasible"]}
    front = {r["key"] for r in local.pareto}

    def dominated(a: tuple[float, float]) -> bool:
        return any(b[0] <= a[0] and b[1] <= a[1] and b != a for b in points.values())

    assert front == {k for k, p in points.items() if not dominated(p)}
    written = sorted((tmp_path / "local" / "pareto").glob("*.yaml"))
    assert len(written) == len(front) >= 2


BAD = [
    ({"variables": []}, "variables", "at least one design variable"),
    ({"variables": [{"path": "joints.lift.actuator.cylinder.bore", "low": 0.2, "high": 0.1}]},
     "variables[0].high", "must exceed low"),
    ({"variables": [{"path": "joints.lift.actuator.cylinder.bore", "catalogue": "iso9999"}]},
     "variables[0].catalogue", "unknown catalogue"),
    ({"objectives": [{"metric": "speed", "sense": "min"}]}, "objectives[0].metric",
     "unknown metric"),
    ({"objectives": [{"metric": "cycle_time"}]}, "objectives[0].metric", "no duty_cycle"),
    ({"objectives": [{"metric": "mass", "sense": "least"}]}, "objectives[0].sense",
     "expected min or max"),
    ({"constraints": [{"metric": "mass"}]}, "constraints[0].min", "needs a min, a max"),
    ({"optimiser": "auto"}, "optimiser", "did you mean 'optimizer'"),
    ({"optimizer": "grid"}, "optimizer", "grid takes categorical and integer variables only"),
    ({"variables": [{"path": "joints.lift.actuator.cylinder.bor", "low": 0.1, "high": 0.2}]},
     "variables[0].path", "bor"),
    ({"objectives": [{"metric": "holding:tilt", "sense": "max"}]}, "objectives[0].metric",
     "no joint 'tilt'"),
    ({"spec": "no_such_arm.yaml"}, "spec", "no_such_arm.yaml"),
]


@pytest.mark.parametrize(("change", "field", "problem"), BAD)
def test_a_bad_study_is_one_line_naming_file_and_field(tmp_path: Path, change: dict[str, Any],
                                                        field: str, problem: str,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    boom(tmp_path)
    study = {"spec": "boom1.yaml", "budget": 4,
             "variables": [{"path": "joints.lift.actuator.cylinder.bore", "low": 0.08,
                            "high": 0.12}],
             "objectives": [{"metric": "mass", "sense": "min"}], **change}
    path = write(tmp_path, "bad.yaml", study)
    with pytest.raises(StudyError) as caught:  # the file's checks, then the arm's
        optimize(path, out=tmp_path / "out", processes=1)
    message = str(caught.value)
    assert "\n" not in message and str(path) in message and f"field '{field}'" in message
    assert problem in message
    code, out, err = run_cli(capsys, "optimize", str(path), "-o", str(tmp_path / "cli"),
                             "--processes", "1")
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and f"field '{field}'" in err


def test_a_study_that_is_not_yaml_is_one_line_with_its_line(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]
                                                            ) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text("spec: boom1.yaml\nvariables: [\n")
    code, _, err = run_cli(capsys, "optimize", str(path), "-o", str(tmp_path / "out"))
    assert code == 2 and len(err.strip().splitlines()) == 1 and f"{path}:" in err


def test_the_command_writes_the_results_and_ml_optimize_is_the_function(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    study = bore_study(tmp_path)
    code, out, err = run_cli(capsys, "optimize", str(study), "-o", str(tmp_path / "cli"),
                             "--processes", "1", "--budget", "30")
    assert code == 0, err
    table = json.loads(out)
    assert table["method"] == "grid" and table["evaluations"] == 27
    code, out, _ = run_cli(capsys, "optimize", str(study), "-o", str(tmp_path / "cli"),
                           "--processes", "1", "--resume")
    assert code == 0 and json.loads(out)["computed"] == 0
    import maniplab.optimize  # noqa: F401 - the package, bound to ml.optimize: still callable

    again = ml.optimize(study, out=tmp_path / "cli", processes=1, resume=True, report=False)
    assert again.computed == 0
    rows = json.loads((tmp_path / "cli" / "evaluations.json").read_text())
    assert rows[0]["phase"] == "baseline" and len(rows) == 1 + 27


def test_a_duty_cycle_is_measured_as_its_runs_say(tmp_path: Path) -> None:
    """The forestry crane's lift moved slowly enough not to be stretched: the cycle time is the
    duration asked; the pump energy is the runs' energy balance (a plugin metric reads the runs
    and sums :func:`maniplab.sim.energy.energy_report`'s pump term); the move ends where it was
    asked, by the analytic model's forward kinematics of the run's last pose."""
    crane = Path(__file__).resolve().parents[1] / "examples" / "optimize" / "forestry_crane.yaml"
    spec = ml.load_spec(crane)
    start = np.array([0.0, -0.3, 1.0, 0.0])
    target = ml.AnalyticModel(spec).fk(np.array([0.0, -0.2, 1.0, 0.0]))[:3, 3]
    (tmp_path / "energy.py").write_text(
        "from maniplab.sim.energy import energy_report\n"
        "def pump(spec, runs):\n"
        "    return sum(energy_report(run).pump for run in runs) / 1e3\n"
        "def last(spec, runs):\n"
        "    import maniplab as ml\n"
        "    return float(((ml.AnalyticModel(spec).fk(runs[-1].q[-1])[:3, 3]\n"
        f"                   - {target.tolist()!r}) ** 2).sum() ** 0.5 * 1e3)\n")
    study = write(tmp_path, "duty.yaml", {
        "spec": str(crane), "budget": 1,
        "variables": [{"path": "joints.tilt.actuator.valve.nominal_flow", "choices": [4.0e-4]}],
        "duty_cycle": {"start": start.tolist(), "settle": 0.5,
                       "moves": [{"target": target.tolist(), "duration": 4.0}]},
        "plugins": {"pump_runs": f"{tmp_path / 'energy.py'}:pump",
                    "miss": f"{tmp_path / 'energy.py'}:last"},
        "objectives": [{"metric": "cycle_time"}],
        "constraints": [{"metric": m, "min": -1e9} for m in
                        ("pump_energy", "pump_runs", "miss", "final_error", "peak_pressure",
                         "health")]})
    result = optimize(study, out=tmp_path / "out", processes=1, sensitivity=False)
    metrics = result.evaluations[0]["metrics"]
    assert metrics["cycle_time"] == 4.0
    assert metrics["pump_energy"] > 0.0
    assert metrics["pump_energy"] == pytest.approx(metrics["pump_runs"], rel=1e-9)
    assert metrics["miss"] == pytest.approx(metrics["final_error"], abs=1e-6)
    assert metrics["final_error"] < 2.0 and metrics["health"] == 0.0
    assert 0.1 < metrics["peak_pressure"] <= 9.0 * 1.01  # MPa, within the relief's setting


def test_the_lowest_natural_frequency_is_the_hydraulic_springs(tmp_path: Path) -> None:
    """A mass on a lumped cylinder's oil springs: ω = sqrt(A² E / (V m)) (Merritt), for each
    candidate mass; the stiffest design is the lightest."""
    area, volume, modulus, payload = 0.002, 0.004, 1.2e9, 100.0
    write(tmp_path, "slide.yaml", {
        "name": "slide", "gravity": [0.0, 0.0, -9.81],
        "joints": [{"name": "x", "type": "P", "axis": "x", "limits": [-0.5, 0.5],
                    "body": {"length": 0.5, "direction": [1, 0, 0], "mass": 300.0},
                    "actuator": {"type": "hydraulic", "area": area, "volume": volume,
                                 "bulk_modulus": modulus, "leakage": 1e-13,
                                 "valve_gain": 5e-4, "valve_tau": 0.01,
                                 "supply_pressure": 20e6}}],
        "end_effector": {"mass": payload}})
    study = write(tmp_path, "stiff.yaml", {
        "spec": "slide.yaml", "budget": 3,
        "variables": [{"path": "joints.x.body.mass", "choices": [200.0, 100.0, 300.0]}],
        "objectives": [{"metric": "frequency_min", "sense": "max"}]})
    result = optimize(study, out=tmp_path / "out", processes=1, sensitivity=False)
    for record in result.evaluations:
        moved = record["values"][0] + payload
        omega = math.sqrt(area**2 * modulus / (volume * moved))
        assert record["metrics"]["frequency_min"] == pytest.approx(omega / (2 * math.pi),
                                                                   rel=1e-6)
    assert result.best is not None and result.best["values"] == [100.0]


def test_nelder_mead_refines_the_base_design_locally(tmp_path: Path) -> None:
    """From the base pins, the local search improves the smallest holding torque, every
    candidate it reports feasible is feasible by the geometry, and it stays below the grid's
    optimum."""
    result = optimize(pin_study(tmp_path, budget=60, optimizer="nelder_mead"),
                      out=tmp_path / "out", processes=1, sensitivity=False)
    q = np.linspace(*LIMITS, 121)
    assert result.method == "nelder_mead" and len(result.evaluations) == 60
    assert result.evaluations[0]["values"] == result.baseline["values"]
    assert result.best is not None
    found = result.best["metrics"]["holding:lift"]
    assert found > 1.05 * result.baseline["metrics"]["holding:lift"]
    x, z = result.best["values"]
    assert found == pytest.approx(float(smallest_holding(np.array(x), np.array(z), q)), rel=1e-6)
    cx, cz = np.meshgrid(np.linspace(*PIN_X, 121), np.linspace(*PIN_Z, 101), indexing="ij")
    assert found <= 1.01 * float(smallest_holding(cx, cz, q).max())


def test_ctrl_c_stops_the_workers_and_leaves_a_resumable_study(tmp_path: Path) -> None:
    """``maniplab optimize`` on two processes, SIGINT while it evaluates: one line, status 130,
    the finished evaluations cached; ``--resume`` computes only the others."""
    import os
    import signal
    import subprocess
    import sys
    import time

    (tmp_path / "slow.py").write_text("import time\n"
                                      "def slow(spec, runs):\n"
                                      "    time.sleep(0.1)\n"
                                      "    return 0.0\n")
    study = pin_study(tmp_path, budget=30, plugins={"slow": f"{tmp_path / 'slow.py'}:slow"},
                      constraints=[{"metric": "slow", "max": 1.0}])
    command = [sys.executable, "-m", "maniplab", "optimize", str(study), "-o",
               str(tmp_path / "out"), "--processes", "2"]
    job = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           cwd=tmp_path)
    cache = tmp_path / "out" / "cache"
    deadline = time.monotonic() + 60
    while len(list(cache.glob("*.json"))) < 6 and time.monotonic() < deadline:
        time.sleep(0.05)
    os.kill(job.pid, signal.SIGINT)
    _, err = job.communicate(timeout=30)
    assert job.returncode == 130 and err.strip().splitlines()[-1] == "maniplab optimize: interrupted"
    stored = len(list(cache.glob("*.json")))
    assert 6 <= stored < 30
    resumed = optimize(study, out=tmp_path / "out", processes=1, resume=True, report=False,
                       sensitivity=False)
    assert resumed.computed == len(list(cache.glob("*.json"))) - stored
    assert resumed.cached >= stored
