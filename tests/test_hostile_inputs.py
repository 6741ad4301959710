"""Hostile inputs, generated: mutated specs, hostile ``--set`` values and corrupted run files
through the command line.

Each case is a file a user (or an attacker) could hand to maniplab. Its outcome is one of

- ``accepted``: exit 0, and the result is right: the exported MJCF loads in plain MuJoCo to the
  model ``ml.build_model`` builds, and a short simulation is finite or refused in one line;
- ``clean``: exit 2 with one line on stderr that names the file;
- ``traceback``: anything else (an exception escaped, several lines, another status);
- ``hang``: no answer within the alarm;
- ``wrong``: accepted, but the result is wrong (a model that differs, NaN in a stored run), or a
  module named by the data was imported.

The test asserts no traceback, hang or wrong output. ``python tests/test_hostile_inputs.py``
prints the table of outcomes.
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import random
import signal
import sys
import zipfile
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import yaml

import maniplab as ml
from maniplab.cli import main

ROOT = Path(__file__).resolve().parents[1]
SEEDS = [ROOT / "src/maniplab/assets/crane3.yaml", ROOT / "src/maniplab/assets/planar2.yaml",
         *sorted((ROOT / "tests/arms").glob("*.yaml"))]
ALARM_S = 60
MARKER_MODULE = "maniplab_hostile_marker"
"""A module on sys.path that writes a marker file when imported: data naming it must not load it."""

Case = tuple[str, bytes]


class Hang(Exception):
    """The alarm went off."""


# --- generated specs --------------------------------------------------------------------------

VALUES: list[Any] = [None, "", "abc", -1, 0, -0.0, 1e308, -1e308, 1e-320, float("nan"),
                     float("inf"), True, [], {}, [1, 2], list(range(10_000)), [[[[[[1]]]]]],
                     "1e5", "é☃\u202e", 10**400, {"type": "x"}]


def _leaves(data: Any, path: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    """Every location in the parsed spec (mappings and lists included)."""
    yield path
    if isinstance(data, dict):
        for key, value in data.items():
            yield from _leaves(value, (*path, key))
    elif isinstance(data, list):
        for index, value in enumerate(data):
            yield from _leaves(value, (*path, index))


def _set(data: Any, path: tuple[Any, ...], value: Any) -> Any:
    if not path:
        return value
    node = data
    for part in path[:-1]:
        node = node[part]
    node[path[-1]] = value
    return data


def _delete(data: Any, path: tuple[Any, ...]) -> Any:
    node = data
    for part in path[:-1]:
        node = node[part]
    del node[path[-1]]
    return data


def _dump(data: Any) -> bytes:
    return yaml.safe_dump(data, allow_unicode=True, sort_keys=False).encode()


def spec_cases(count_per_seed: int = 40) -> list[Case]:
    """Mutated seeds (a value replaced, a key removed or added, a joint repeated) and files that
    are not specs at all, deterministic."""
    rng = random.Random(20261125)
    cases: list[Case] = []
    for seed in SEEDS:
        base = yaml.safe_load(seed.read_text())
        paths = list(_leaves(base))[1:]
        for k in range(count_per_seed):
            data, path = copy.deepcopy(base), rng.choice(paths)
            kind = k % 4
            if kind == 0 or kind == 1:
                value = rng.choice(VALUES)
                data = _set(data, path, copy.deepcopy(value))
                what = f"{'.'.join(map(str, path))}={str(value)[:20]!r}"
            elif kind == 2:
                data, what = _delete(data, path), f"del {'.'.join(map(str, path))}"
            else:
                joints = data["joints"]
                joints.append(copy.deepcopy(rng.choice(joints)))
                what = "joint repeated"
            try:
                text = _dump(data)
            except (ValueError, OverflowError):  # 10**400 has no YAML float: write it raw
                text = _dump(_set(data, path, "PLACEHOLDER")).replace(b"PLACEHOLDER", b"1" + b"0" * 400)
            cases.append((f"{seed.stem}: {what}", text))
    return cases + _non_specs()


def _non_specs() -> list[Case]:
    good = (ROOT / "src/maniplab/assets/crane3.yaml").read_bytes()
    bomb = b"a: &a [x, x, x, x, x, x, x, x, x]\n" + b"".join(
        f"{c}: &{c} [{', '.join(['*' + p] * 9)}]\n".encode()
        for p, c in zip("abcdefgh", "bcdefghi"))
    return [
        ("empty file", b""), ("null", b"null\n"), ("a list", b"[1, 2]\n"), ("a number", b"42\n"),
        ("binary", bytes(range(256)) * 8), ("NUL bytes", b"name: x\0\n"),
        ("invalid UTF-8", b"name: \xff\xfe\n" + good), ("tabs", b"name:\tx\n\tjoints: []\n"),
        ("python tag", b"!!python/object/apply:os.system ['touch /tmp/maniplab-pwned']\n"),
        ("alias bomb", bomb), ("2 MB of comments", good + b"#" * 2_000_000),
        ("deep nesting", b"a: " + b"[" * 5000 + b"]" * 5000 + b"\n"),
        ("duplicate key", good + b"name: again\n"),
        ("marker plugin", good.replace(b"type: hydraulic", f"type: '{MARKER_MODULE}:X'".encode(), 1)),
        ("this:s plugin", good.replace(b"type: hydraulic", b"type: 'this:s'", 1)),
        ("comment injection", good.replace(b"name: crane3",
                                           b"name: 'x --> <option gravity=\"0 0 50\"/> <!-- y'")),
        ("include injection", good.replace(b"name: crane3",
                                           b"name: '--><include file=\"/etc/passwd\"/><!--'")),
        ("huge gravity", good.replace(b"gravity: [0.0, 0.0, -9.81]", b"gravity: [0, 0, -1e308]")),
    ]


# --- hostile values through --set ----------------------------------------------------------------

SET_VALUES = ["0", "-1", "1e308", "-1e308", "nan", "inf", "1e-320", "abc", "[1,2,3]", "{}",
              "null", "true", "1e18", "-1e18", "1e-18", "-0.0", "[nan,0,0]"]


def set_cases() -> list[Case]:
    """Every parameter of crane3 (as ``--set`` names it) given each hostile value."""
    from maniplab.sim import params

    return [(f"--set {path}={value}", f"{path}={value}".encode())
            for path in params.flatten_spec(ml.builtin_spec("crane3")) for value in SET_VALUES]


def set_outcome(path: Path, work: Path) -> tuple[str, str]:
    """(outcome, detail) of simulating crane3 with the override held in the file ``path``: a run
    that is stored must read back (its spec included) and be finite."""
    run = work / "run.npz"
    status, _, err = _cli("simulate", "crane3", "--duration", "0.01",
                          "--set", path.read_text(), "-o", str(run))
    if status == 0:
        try:
            stored = ml.Run.load(run)
        except ml.ManiplabError as exc:
            return "wrong", f"the stored run does not read back: {exc}"
        finite = np.isfinite(stored.q).all() and np.isfinite(stored["qd"]).all()
        return ("accepted", "") if finite else ("wrong", "a stored run holds NaN")
    lines = err.strip().splitlines()
    clean = status == 2 and len(lines) == 1 and "Traceback" not in err
    return ("clean" if clean else "traceback"), err.strip()


# --- generated run files ----------------------------------------------------------------------

def _members(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {name: data[name] for name in data.files}


def _rewrite(members: dict[str, np.ndarray], edit: Callable[[dict[str, Any], dict[str, np.ndarray]], None],
             rehash: bool = True) -> bytes:
    """A run file with ``edit`` applied to its header and arrays, re-hashed so that only the edit
    is wrong."""
    from maniplab.sim.store import content_hash

    members = dict(members)
    header = json.loads(str(members["header"]))
    edit(header, members)
    signals = {k.removeprefix("signal/"): v for k, v in members.items() if k.startswith("signal/")}
    if rehash:
        header["hash"] = content_hash(members["t"], signals, header)
    members["header"] = np.array(json.dumps(header))
    out = io.BytesIO()
    np.savez(out, **members)  # type: ignore[arg-type]
    return out.getvalue()


def run_cases(good: Path) -> list[Case]:
    """A good run file cut, flipped and edited in the ways a disk, a network or a person does."""
    raw = good.read_bytes()
    members = _members(good)
    rng = random.Random(7)
    cases: list[Case] = [(f"cut at {f:.2f}", raw[:int(f * len(raw))]) for f in (0, 0.01, 0.3, 0.7, 0.99)]
    for k in range(12):
        flipped = bytearray(raw)
        flipped[rng.randrange(len(raw))] ^= 1 << rng.randrange(8)
        cases.append((f"bit flip {k}", bytes(flipped)))
    cases.append(("a text file", b"this is not a run\n"))
    pickled = io.BytesIO()
    np.savez(pickled, t=np.arange(3.0), header=np.array([{"a": 1}], dtype=object))
    cases.append(("object array (pickle)", pickled.getvalue()))
    other = io.BytesIO()
    np.savez(other, x=np.arange(3.0))
    cases.append(("another npz", other.getvalue()))

    def edit(name: str, change: Callable[[dict[str, Any], dict[str, np.ndarray]], None],
             rehash: bool = True) -> None:
        cases.append((name, _rewrite(members, change, rehash)))

    edit("hash mismatch", lambda h, m: m.__setitem__("t", m["t"] + 1.0), rehash=False)
    edit("format 99", lambda h, m: h.__setitem__("format", "maniplab-run/99"))
    edit("no spec", lambda h, m: h.pop("spec"))
    edit("spec not a mapping", lambda h, m: h.__setitem__("spec", [1, 2]))
    edit("spec invalid", lambda h, m: h["spec"]["joints"][0].__setitem__("type", "X"))
    edit("spec with a marker plugin", lambda h, m: h["spec"]["joints"][0].__setitem__(
        "actuator", {"type": f"{MARKER_MODULE}:X"}))
    edit("t shorter than the signals", lambda h, m: m.__setitem__("t", m["t"][:-3]))
    edit("a signal of the wrong width", lambda h, m: m.__setitem__("signal/q", m["signal/q"][:, :1]))
    edit("t of strings", lambda h, m: m.__setitem__("t", m["t"].astype(str)))
    edit("header not JSON", lambda h, m: h.clear())
    edit("meta a string", lambda h, m: h.__setitem__("meta", "x"))
    huge = io.BytesIO()
    with zipfile.ZipFile(huge, "w") as archive:  # an .npy header that claims 10^12 samples
        stream = io.BytesIO()
        np.lib.format.write_array_header_1_0(stream, {"descr": "<f8", "fortran_order": False,
                                                      "shape": (10**12,)})
        body = stream.getvalue() + b"\0" * 64
        archive.writestr("t.npy", bytes(body))
        archive.writestr("header.npy", _npy(np.array(str(members["header"]))))
    cases.append(("claims 10^12 samples", huge.getvalue()))
    bare = io.BytesIO()
    with zipfile.ZipFile(bare, "w") as archive:  # members without the .npy suffix
        archive.writestr("header", str(members["header"]))
        archive.writestr("t", b"\0" * 64)
    cases.append(("members without .npy", bare.getvalue()))
    return cases


def _npy(array: np.ndarray) -> bytes:
    out = io.BytesIO()
    np.save(out, array)
    return out.getvalue()


# --- running a case ---------------------------------------------------------------------------

@contextlib.contextmanager
def _alarm(seconds: int) -> Iterator[None]:
    def ring(signum: int, frame: Any) -> None:
        raise Hang

    previous = signal.signal(signal.SIGALRM, ring)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def _cli(*argv: str) -> tuple[int | None, str, str]:
    """Run the command in this process: (status, stdout, stderr); status None for an escaped
    exception (its traceback in stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status: int | None = main(list(argv))
        except SystemExit as exc:
            status = exc.code if isinstance(exc.code, int) else 2
        except Hang:
            raise
        except BaseException as exc:  # noqa: BLE001 - the point is to see it
            status, err = None, io.StringIO(f"Traceback: {type(exc).__name__}: {exc}")
    return status, out.getvalue(), err.getvalue()


def _error_outcome(status: int | None, err: str, path: Path) -> str:
    lines = err.strip().splitlines()
    if status == 2 and len(lines) == 1 and "Traceback" not in err and path.name in lines[0]:
        return "clean"
    return "traceback"


def spec_outcome(path: Path, work: Path) -> tuple[str, str]:
    """(outcome, detail) of validating, exporting and simulating the spec at ``path``."""
    status, _, err = _cli("validate", str(path))
    if status != 0:
        return _error_outcome(status, err, path), err.strip()
    xml = work / "model.xml"
    status, _, err = _cli("export", str(path), "-o", str(xml))
    if status != 0:
        return "traceback", f"validates but export says: {err.strip()}"
    detail = _same_model(path, xml)
    if detail:
        return "wrong", detail
    run = work / "run.npz"
    status, _, err = _cli("simulate", str(path), "--duration", "0.02", "-o", str(run))
    if status == 0:
        stored = ml.Run.load(run)
        if not (np.isfinite(stored.q).all() and np.isfinite(stored["qd"]).all()):
            return "wrong", "a stored run holds NaN"
        run.unlink()
        return "accepted", ""
    return _error_outcome(status, err, path), err.strip()


def _same_model(spec_path: Path, xml: Path) -> str:
    """'' when the exported file loads in plain MuJoCo to the model build_model gives."""
    built = ml.build_model(spec_path)
    try:
        loaded = mujoco.MjModel.from_xml_path(str(xml))
    except ValueError as exc:
        return f"the exported file does not load in MuJoCo: {str(exc).splitlines()[0]}"
    for name in ("opt.gravity", "body_mass", "body_inertia", "body_pos", "jnt_range", "jnt_axis",
                 "dof_damping", "actuator_gainprm", "actuator_biasprm", "actuator_dynprm"):
        a = _attr(built, name)
        b = _attr(loaded, name)
        if a.shape != b.shape or not np.allclose(a, b, rtol=1e-12, atol=0, equal_nan=True):
            return f"exported {name} differs from build_model's"
    if not np.isfinite(loaded.opt.gravity).all():
        return "gravity not finite"
    return ""


def _attr(model: Any, dotted: str) -> np.ndarray:
    value = model
    for part in dotted.split("."):
        value = getattr(value, part)
    return np.asarray(value, dtype=float)


def run_outcome(path: Path, work: Path) -> tuple[str, str]:
    """(outcome, detail) of loading, listing and comparing the run file at ``path``."""
    folder = path.parent
    status, out, err = _cli("runs", str(folder))
    listed = status == 0 and path.name in out
    if status not in (0, 2) or (status == 2 and _error_outcome(status, err, path) != "clean"):
        return "traceback", f"runs: {err.strip()}"
    status, _, err = _cli("compare", str(path), "-o", str(work / "c.png"))
    if status == 0:
        return ("accepted" if listed else "wrong"), "" if listed else "compare reads what runs refused"
    return _error_outcome(status, err, path), err.strip()


def _marker_module(folder: Path) -> Path:
    """A module named by hostile data; importing it writes the returned marker file."""
    marker = folder / "imported"
    (folder / f"{MARKER_MODULE}.py").write_text(
        f"open({str(marker)!r}, 'w').write('x')\nclass X: pass\n")
    return marker


def outcomes(work: Path) -> tuple[Counter[str], list[str]]:
    """Every generated case run in ``work``: the count per outcome and the bad ones' details."""
    marker = _marker_module(work)
    sys.path.insert(0, str(work))
    counts: Counter[str] = Counter()
    bad: list[str] = []
    try:
        for kind, cases, judge in (("spec", spec_cases(), spec_outcome),
                                   ("set", set_cases(), set_outcome),
                                   ("run", run_cases(_good_run(work)), run_outcome)):
            for k, (name, data) in enumerate(cases):
                folder = work / f"{kind}{k}"
                folder.mkdir()
                path = folder / f"case{k}.{ {'spec': 'yaml', 'set': 'txt'}.get(kind, 'npz')}"
                path.write_bytes(data)
                try:
                    with _alarm(ALARM_S):
                        outcome, detail = judge(path, folder)
                except Hang:
                    outcome, detail = "hang", f"no answer in {ALARM_S} s"
                if marker.exists():
                    outcome, detail = "wrong", f"imported {MARKER_MODULE}"
                    marker.unlink()
                counts[f"{kind} {outcome}"] += 1
                if outcome not in ("accepted", "clean"):
                    bad.append(f"{kind} '{name}': {outcome}: {detail}")
    finally:
        sys.path.remove(str(work))
    return counts, bad


def _good_run(work: Path) -> Path:
    path = work / "good.npz"
    ml.simulate("crane3", duration=0.05, inputs={"luff": ml.signals.step(0.3)}).save(path)
    return path


def test_no_hostile_input_gives_a_traceback_a_hang_or_a_wrong_result(tmp_path: Path) -> None:
    counts, bad = outcomes(tmp_path)
    assert not bad, "\n".join(bad)
    assert counts["spec clean"] > 100 and counts["spec accepted"] > 20  # the mutations bite
    assert counts["run clean"] > 20
    assert counts["set clean"] > 1000 and counts["set accepted"] > 100


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        counts, bad = outcomes(Path(folder))
    for kind in ("spec", "set", "run"):
        tried = sum(v for k, v in counts.items() if k.startswith(kind))
        row = ", ".join(f"{o} {counts[f'{kind} {o}']}"
                        for o in ("accepted", "clean", "traceback", "hang", "wrong"))
        what = {"spec": "spec files", "set": "--set values", "run": "run files"}[kind]
        print(f"{what}: tried {tried}: {row}")
    print("\n".join(bad) or "no traceback, hang or wrong result")
