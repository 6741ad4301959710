"""The MATLAB/Octave export run in GNU Octave against the analytic model.

Every built-in arm and every arm of tests/arms is exported; ONE octave-cli process evaluates the
exported functions of all of them on seeded random states (read from text files written with 17
significant digits, so Octave sees the very doubles Python drew) and writes the results back with
17 digits. They must equal :class:`~maniplab.model.AnalyticModel`'s (itself checked against MuJoCo
in test_model.py) to 1e-12, and the pinned cylinders' lengths and moment arms must equal those of
their pin geometry. GNU Octave is required: without it these tests fail, they never skip.
"""

from __future__ import annotations

import shutil
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from commandline import run_cli

import maniplab as ml
from maniplab.actuators.hydraulic.pinned import PinnedCylinder
from maniplab.model import AnalyticModel
from maniplab.model.matlab import export_matlab, matlab_prefix
from maniplab.spec import model_of

ARMS_DIR = Path(__file__).parent / "arms"
OCTAVE = shutil.which("octave-cli") or shutil.which("octave")
STATES = 5
#: Agreement required, relative to max(1, the largest entry of the reference value). The MATLAB
#: code performs the same double operations in the same order as the compiled model, so the only
#: differences are sin/cos/sqrt of two libraries (under an ulp each); the erector's entries reach
#: 1e5 (kg m^2, N m), where one ulp is 1.5e-11: an absolute 1e-12 would ask for less than the
#: last bit. Relative to the largest entry (and absolute below 1), 1e-12 is still ~5000 ulp.
TOLERANCE = 1e-12
DYNAMICS = ("M", "C", "G", "bias", "inverse_dynamics", "fk", "jacobian")


def _arms() -> list[tuple[str, ml.ManipulatorSpec]]:
    arms = [(name, ml.builtin_spec(name)) for name in ml.builtin_specs()]
    return arms + [(f"arms/{path.stem}", ml.load_spec(path))
                   for path in sorted(ARMS_DIR.glob("*.yaml"))]


ARMS = _arms()


@dataclass
class Case:
    """One Octave evaluation: an exported folder, its states and (optionally) a changed p."""

    key: str
    spec: ml.ManipulatorSpec
    folder: Path
    changes: dict[int, float] = field(default_factory=dict)  # 0-based p index -> new value
    states: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)
    results: dict[tuple[str, int], np.ndarray] = field(default_factory=dict)


def _require_octave() -> str:
    if OCTAVE is None:
        pytest.fail("GNU Octave not found (octave-cli): install GNU Octave (apt-get install octave)")
    return OCTAVE


def _octave_script(case: Case) -> str:
    """Evaluate every function of the case's export on its states, writing one line per value."""
    a, n = matlab_prefix(case.spec.name), case.spec.n
    idx = " ".join(str(i + 1) for i in case.changes)
    vals = " ".join(f"{v!r}" for v in case.changes.values())
    calls = "\n".join(
        f"  emit(fid, '{fn}', r, {a}_{fn}({args}, p));" for fn, args in
        (("M", "q"), ("C", "q, qd"), ("G", "q"), ("bias", "q, qd"),
         ("inverse_dynamics", "q, qd, qdd"), ("fk", "q"), ("jacobian", "q")))
    return f"""
addpath('{case.folder}');
S = load('-ascii', '{case.folder / "states.txt"}');
fid = fopen('{case.folder / "results.txt"}', 'w');
p = {a}_params();
emit(fid, 'params', 0, p);
emit(fid, 'fv', 0, {a}_fv());
emit(fid, 'labels', 0, numel({a}_param_labels()));
p([{idx}]) = [{vals}];
for r = 1:rows(S)
  q = S(r, 1:{n}); qd = S(r, {n + 1}:{2 * n}); qdd = S(r, {2 * n + 1}:{3 * n});
  if mod(r, 2)
    q = q'; qdd = qdd';  % rows and columns both accepted
  end
{calls}
  emit(fid, 'default_M', r, {a}_M(q));
  emit(fid, 'cylinder_length', r, {a}_cylinder_length(q));
  emit(fid, 'moment_arm', r, {a}_moment_arm(q));
end
fclose(fid);
rmpath('{case.folder}');
"""


_EMIT = """1;
function emit(fid, name, r, X)
  fprintf(fid, '%s %d %d %d', name, r, rows(X), columns(X));
  fprintf(fid, ' %.17g', X);
  fprintf(fid, '\\n');
end
"""


@pytest.fixture(scope="module")
def octave_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Case]:
    """All arms (and two changed parameter vectors) evaluated by one octave-cli process."""
    octave = _require_octave()
    root = tmp_path_factory.mktemp("matlab")
    cases = [Case(key, spec, root / f"arm{i}") for i, (key, spec) in enumerate(ARMS)]
    for key, overrides in (("erector", {"end_effector.mass": 6000.0}),
                           ("arms/loader_crane", {"joints.1.body.mass": 700.0})):
        spec = dict(ARMS)[key].with_overrides(overrides)
        base, changed = AnalyticModel(dict(ARMS)[key]).params, AnalyticModel(spec).params
        assert base.shape == changed.shape
        diff = np.flatnonzero(base != changed)
        assert diff.size, overrides
        cases.append(Case(f"{key}+p", spec, root / f"p_{len(cases)}",
                          {int(i): float(changed[i]) for i in diff}))
    for i, case in enumerate(cases):
        # a changed-p case exports the unchanged arm: only p (set in Octave) carries the change
        export_matlab(dict(ARMS)[case.key.removesuffix("+p")], case.folder)
        rng = np.random.default_rng(100 + i)
        case.states = [tuple(rng.uniform(-2.0, 2.0, size=(3, case.spec.n)))
                       for _ in range(STATES)]
        np.savetxt(case.folder / "states.txt",
                   np.array([np.concatenate(s) for s in case.states]), fmt="%.17g")
    script = root / "run_all.m"
    script.write_text(_EMIT + "".join(_octave_script(c) for c in cases))
    start = time.perf_counter()
    done = subprocess.run([octave, "--no-gui", "--norc", "--quiet", str(script)],
                          check=False, capture_output=True, text=True, timeout=300)
    elapsed = time.perf_counter() - start
    # Octave 7 prints "error: ignoring const execution_exception& while preparing to exit" on
    # every exit (Debian bug 1022473): only the status and other lines tell a failure
    assert done.returncode == 0, done.stderr
    print(f"octave-cli: {len(cases)} cases in {elapsed:.2f} s")
    for case in cases:
        for line in (case.folder / "results.txt").read_text().splitlines():
            name, r, rows, cols, *values = line.split()
            case.results[name, int(r)] = np.array([float(v) for v in values]).reshape(
                (int(rows), int(cols)), order="F")
    return {c.key: c for c in cases}


def _error(got: np.ndarray, ref: np.ndarray, what: str) -> float:
    """The error relative to max(1, |largest entry|), asserted below TOLERANCE."""
    assert got.shape == ref.shape, (what, got.shape, ref.shape)
    err = float(np.max(np.abs(got - ref), initial=0.0) / max(1.0, float(np.max(np.abs(ref)))))
    assert err <= TOLERANCE, f"{what}: error {err:.3g}\ngot {got}\nexpected {ref}"
    return err


def _check_dynamics(case: Case, am: AnalyticModel) -> dict[str, float]:
    worst = dict.fromkeys(DYNAMICS, 0.0)
    n = case.spec.n
    for r, (q, qd, qdd) in enumerate(case.states, start=1):
        refs = {"M": am.M(q), "C": am.C(q, qd), "G": am.G(q)[:, None],
                "bias": am.bias(q, qd)[:, None],
                "inverse_dynamics": am.inverse_dynamics(q, qd, qdd)[:, None],
                "fk": am.fk(q), "jacobian": am.jacobian(q)}
        assert refs["M"].shape == (n, n) and refs["jacobian"].shape == (6, n)
        for fn, ref in refs.items():
            err = _error(case.results[fn, r], ref, f"{case.key} {fn} state {r}")
            worst[fn] = max(worst[fn], err)
    return worst


@pytest.mark.parametrize("key", [key for key, _ in ARMS])
def test_octave_matches_the_analytic_model(key: str, octave_runs: dict[str, Case]) -> None:
    case = octave_runs[key]
    am = AnalyticModel(case.spec)
    worst = _check_dynamics(case, am)
    print(f"{key}: max errors " + ", ".join(f"{fn} {e:.2g}" for fn, e in worst.items()))
    # the parameter vector is the model's to the last bit (repr literals read back exactly)
    np.testing.assert_array_equal(case.results["params", 0][:, 0], am.params)
    assert case.results["labels", 0][0, 0] == len(am.param_labels)
    np.testing.assert_array_equal(case.results["fv", 0][:, 0],
                                  [j.friction.viscous for j in case.spec.joints])


@pytest.mark.parametrize("key", [key for key, _ in ARMS])
def test_octave_cylinder_terms_match_the_pin_geometry(key: str,
                                                      octave_runs: dict[str, Case]) -> None:
    case = octave_runs[key]
    pinned = {j: model_of(joint) for j, joint in enumerate(case.spec.joints)}
    for r, (q, _, _) in enumerate(case.states, start=1):
        length, arm = case.results["cylinder_length", r][:, 0], case.results["moment_arm", r][:, 0]
        for j, actuator in pinned.items():
            if isinstance(actuator, PinnedCylinder):
                _error(np.array([length[j]]), np.array([actuator.geometry.length(q[j])]),
                       f"{key} s{j + 1}")
                _error(np.array([arm[j]]), np.array([actuator.geometry.arm(q[j])]),
                       f"{key} r{j + 1}")
            else:
                assert np.isnan(length[j]) and np.isnan(arm[j])


@pytest.mark.parametrize("key", ["erector", "arms/loader_crane"])
def test_octave_honours_the_parameter_vector(key: str, octave_runs: dict[str, Case]) -> None:
    """p changed in Octave (a heavier payload; a lighter main boom) gives the model of the spec
    with that mass changed, not the exported spec's."""
    case = octave_runs[f"{key}+p"]
    _check_dynamics(case, AnalyticModel(case.spec))
    base = AnalyticModel(dict(ARMS)[key])
    for r, (q, _, _) in enumerate(case.states, start=1):
        np.testing.assert_allclose(case.results["default_M", r], base.M(q), rtol=0, atol=1e-9)
        assert not np.allclose(case.results["M", r], base.M(q), rtol=1e-6)


def test_prefix_is_a_valid_matlab_name() -> None:
    assert matlab_prefix("loader-crane") == "loader_crane"
    assert matlab_prefix("6dof arm") == "arm_6dof_arm"
    assert matlab_prefix("_x") == "arm__x"
    assert matlab_prefix("bras-été") == "bras__t_"
    assert len(matlab_prefix("a" * 100) + "_inverse_dynamics") == 63


def test_a_name_starting_with_a_digit_runs_in_octave(tmp_path: Path) -> None:
    octave = _require_octave()
    spec = ml.builtin_spec("planar2").with_overrides({"name": "2-link"})
    export_matlab(spec, tmp_path)
    assert (tmp_path / "arm_2_link_M.m").is_file()
    done = subprocess.run([octave, "--no-gui", "--norc", "--quiet", "--eval",
                           f"addpath('{tmp_path}'); fprintf('%.17g ', arm_2_link_M([0.3 -0.2]))"],
                          check=False, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    got = np.array([float(v) for v in done.stdout.split()]).reshape(2, 2, order="F")
    _error(got, AnalyticModel(spec).M([0.3, -0.2]), "2-link M")


def test_cli_writes_the_folder_and_keeps_other_files(capsys: pytest.CaptureFixture[str],
                                                      tmp_path: Path) -> None:
    out = tmp_path / "matlab"
    out.mkdir()
    (out / "mine.m").write_text("% mine\n")
    (out / "loader_crane_M.m").write_text("% an earlier export\n")
    code, stdout, err = run_cli(capsys, "model", str(ARMS_DIR / "loader_crane.yaml"), "-f",
                                "matlab", "-o", str(out))
    assert code == 0 and err == "" and "13 files loader_crane_*" in stdout
    assert (out / "mine.m").read_text() == "% mine\n"
    names = {p.name for p in out.iterdir()}
    assert {"loader_crane_M.m", "loader_crane_inverse_dynamics.m", "loader_crane_params.m",
            "loader_crane_README.txt"} <= names
    assert not any(name.startswith(".") for name in names)  # no temporary file left
    assert (out / "loader_crane_M.m").read_text().startswith("function M = loader_crane_M(q, p)")
    # a new folder (and its parents) is created
    code, _, _ = run_cli(capsys, "model", "planar2", "-f", "matlab", "-o", str(tmp_path / "a/b"))
    assert code == 0 and (tmp_path / "a/b/planar2_jacobian.m").is_file()


@pytest.mark.parametrize("argv, message", [
    (["-f", "matlab", "-o", "{file}"], "exists and is not a folder"),
    (["-f", "matlab"], "required: -o/--output"),
    (["-o", "{tmp}"], "give --format matlab"),
    (["-f", "matlab", "-o", "{file}/sub"], "Not a directory"),
])
def test_cli_refuses_bad_input_in_one_line(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                           argv: list[str], message: str) -> None:
    (tmp_path / "file").write_text("mine")
    argv = [a.format(tmp=tmp_path, file=tmp_path / "file") for a in argv]
    code, out, err = run_cli(capsys, "model", "planar2", *argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and message in err, err
    assert (tmp_path / "file").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_a_folder_in_the_way_of_a_file_is_refused_before_writing(tmp_path: Path) -> None:
    (tmp_path / "planar2_G.m").mkdir()
    with pytest.raises(ml.ManiplabError, match="planar2_G.m"):
        export_matlab(ml.builtin_spec("planar2"), tmp_path)
    assert [p.name for p in tmp_path.iterdir()] == ["planar2_G.m"]
