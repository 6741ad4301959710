"""Mutation testing of maniplab's physics, control, identification, FMU and load-chart code.

``make mutants`` (not part of ``make test``). Each mutant is one small change to one source file
(an operator swapped, a comparison loosened, a number changed, a sign or a term dropped) made in a
private copy of the repository (``git archive HEAD`` into a temporary folder, its own
``PYTHONPATH`` and ``MANIPLAB_CACHE``), never in the working tree; a focused subset of the tests
chosen per group runs against it (``pytest -x``, stopping at the first failure). A mutant is
*killed* when a test fails (or the run exceeds three times the unmutated run plus a minute:
*timeout*), *survived* when every test passes. The mutated file is restored in a ``finally`` after
each mutant and the copy is deleted at the end, Ctrl-C included.

The Python mutants come from the syntax tree (no docstrings, strings, f-strings or type
annotations), the C mutants from the tokens of the code outside comments, strings and
preprocessor lines. All mutants of the chosen groups are listed in a fixed order; ``--sample N``
takes N of each group with a fixed seed (``--seed``), ``--sample 0`` all of them.

Usage::

    python tests/mutants/run.py                       # the default sample of every group
    python tests/mutants/run.py --groups loadchart --sample 0
    python tests/mutants/run.py --list                # the mutants, not run
    python tests/mutants/run.py --rerun out/mutants/results.jsonl --out out/mutants-rerun

Results: one JSON line per mutant and a Markdown summary in ``--out`` (default out/mutants/).
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import functools
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

HYDRAULIC_TESTS = ["tests/test_hydraulic_edges.py", "tests/test_valve_law.py",
                   "tests/test_mutation_survivors.py", "tests/test_cylinder_physics.py",
                   "tests/test_pinned_geometry.py", "tests/test_sim_hydraulic.py",
                   "tests/test_actuators.py"]

GROUPS: dict[str, tuple[list[str], list[str]]] = {
    # group: (sources, the focused tests run against each of their mutants, fastest first)
    "hydraulics": (["src/maniplab/actuators/hydraulic/valve.py",
                    "src/maniplab/actuators/hydraulic/chambers.py",
                    "src/maniplab/actuators/hydraulic/chamber_steady.py",
                    "src/maniplab/actuators/hydraulic/geometry.py",
                    "src/maniplab/actuators/hydraulic/pinned.py"], HYDRAULIC_TESTS),
    "friction": (["src/maniplab/friction/lugre.py", "src/maniplab/friction/modes.py"],
                 ["tests/test_friction_lugre.py", "tests/test_actuators.py",
                  "tests/test_mutation_survivors.py", "tests/test_friction_hybrid.py",
                  "tests/test_cylinder_physics.py::test_relief_caps_the_pressure_at_a_stop"]),
    "native": (["src/maniplab_native/chambers.h", "src/maniplab_native/cylinder.c",
                "src/maniplab_native/valve.h", "src/maniplab_native/hydraulic.c",
                "src/maniplab_native/lugre.c"],
               HYDRAULIC_TESTS + ["tests/test_valve_native.py", "tests/test_native_plugins.py",
                                  "tests/test_friction_lugre.py"]),
    "control": (["src/maniplab/control/pid.py", "src/maniplab/control/trajectory.py",
                 "src/maniplab/control/inverse_dynamics.py", "src/maniplab/control/kinematics.py",
                 "src/maniplab/control/cascade.py", "src/maniplab/control/metrics.py"],
                ["tests/test_control_pid.py", "tests/test_control_trajectory.py",
                 "tests/test_control_kinematics.py", "tests/test_control_blocks.py",
                 "tests/test_control_cascade.py", "tests/test_mutation_survivors.py"]),
    "identification": (["src/maniplab/identification/fit.py",
                        "src/maniplab/identification/data.py",
                        "src/maniplab/identification/parameters.py"],
                       # the fast tests of test_identify.py (the whole file takes minutes)
                       ["tests/test_identify.py::test_a_bad_parameter_is_one_line",
                        ("tests/test_identify.py::test_a_bad_csv_is_one_line_naming_the_file_and_"
                        "column"),
                        "tests/test_identify.py::test_held_inputs_keep_each_sample_until_the_next",
                        "tests/test_mutation_survivors.py",
                        "tests/test_identify_intervals.py",
                        ("tests/test_identify.py::test_payload_leakage_and_bulk_modulus_are_"
                        "recovered_on_crane3"),
                        ("tests/test_identify.py::test_two_parameters_the_data_cannot_separate_"
                        "are_flagged")]),
    "fmu": (["src/maniplab/fmu/variables.py", "src/maniplab/fmu/description.py"],
            ["tests/test_fmu_units.py", "tests/test_mutation_survivors.py", "tests/test_fmu.py"]),
    "loadchart": (["src/maniplab/loadchart.py"],
                  ["tests/test_loadchart.py", "tests/test_mutation_survivors.py"]),
}

DEFAULT_SAMPLE = 12
"""Mutants drawn per group by default (``--sample 0``: all)."""


@dataclasses.dataclass(frozen=True)
class Mutant:
    """One change to one file: the characters [start, end) replaced by ``text``."""

    group: str
    path: str
    line: int
    start: int
    end: int
    text: str
    kind: str

    def apply(self, source: str) -> str:
        return source[:self.start] + self.text + source[self.end:]

    def describe(self, source: str) -> str:
        """The changed line before and after, for the report."""
        first = source.rfind("\n", 0, self.start) + 1
        last = source.find("\n", self.end)
        last = len(source) if last < 0 else last
        before = source[first:last]
        after = self.apply(source)[first:last + len(self.text) - (self.end - self.start)]
        return f"`{before.strip()}` → `{after.strip()}`"


# --- Python mutants, from the syntax tree ---------------------------------------------------------

_BINARY = {ast.Add: ("+", "-"), ast.Sub: ("-", "+"), ast.Mult: ("*", "/"), ast.Div: ("/", "*"),
           ast.Pow: ("**", "*"), ast.FloorDiv: ("//", "/")}
_COMPARE = {ast.Lt: ("<", "<="), ast.LtE: ("<=", "<"), ast.Gt: (">", ">="), ast.GtE: (">=", ">"),
            ast.Eq: ("==", "!="), ast.NotEq: ("!=", "==")}


class _Offsets:
    """Character offsets of (line, UTF-8 column) positions of a source."""

    def __init__(self, source: str) -> None:
        self.lines = source.splitlines(keepends=True)
        self.starts = [0]
        for line in self.lines:
            self.starts.append(self.starts[-1] + len(line))

    def __call__(self, lineno: int, col: int) -> int:
        line = self.lines[lineno - 1]
        return self.starts[lineno - 1] + len(line.encode()[:col].decode())


def _skipped(tree: ast.AST) -> set[int]:
    """ids of the nodes not to mutate: annotations, f-strings, docstrings."""
    skip: set[int] = set()

    def mark(node: ast.AST | None) -> None:
        if node is not None:
            skip.update(id(n) for n in ast.walk(node))

    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            mark(node.returns)
            for a in [*node.args.args, *node.args.kwonlyargs, *node.args.posonlyargs,
                      node.args.vararg, node.args.kwarg]:
                if a is not None:
                    mark(a.annotation)
        elif isinstance(node, ast.AnnAssign):
            mark(node.annotation)
        elif isinstance(node, ast.JoinedStr):
            mark(node)
    return skip


def python_mutants(group: str, path: str, source: str) -> list[Mutant]:
    tree = ast.parse(source)
    at = _Offsets(source)
    skip = _skipped(tree)
    out: list[Mutant] = []

    def gap_token(left: ast.AST, right: ast.AST, symbol: str) -> tuple[int, int] | None:
        a = at(left.end_lineno or 0, left.end_col_offset or 0)
        b = at(right.lineno, right.col_offset)
        gap = re.sub(r"#[^\n]*", lambda m: " " * len(m.group()), source[a:b])
        match = re.search(r"(?<![*/<>=!])" + re.escape(symbol) + r"(?![*/<>=])", gap)
        return (a + match.start(), a + match.end()) if match else None

    for node in ast.walk(tree):
        if id(node) in skip or not hasattr(node, "lineno"):
            continue
        line = node.lineno
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            old, new = _BINARY[type(node.op)]
            span = gap_token(node.left, node.right, old)
            if span:
                out.append(Mutant(group, path, line, *span, new, f"{old} -> {new}"))
            if isinstance(node.op, (ast.Add, ast.Sub)):  # the right term dropped
                a = at(node.lineno, node.col_offset)
                b = at(node.end_lineno or 0, node.end_col_offset or 0)
                left = ast.get_source_segment(source, node.left) or ""
                if left and not isinstance(node.left, ast.Constant):
                    out.append(Mutant(group, path, line, a, b, f"({left})", f"drop {old} term"))
        elif isinstance(node, ast.Compare):
            previous = node.left
            for op, right in zip(node.ops, node.comparators):
                if type(op) in _COMPARE:
                    old, new = _COMPARE[type(op)]
                    span = gap_token(previous, right, old)
                    if span:
                        out.append(Mutant(group, path, line, *span, new, f"{old} -> {new}"))
                previous = right
        elif isinstance(node, ast.BoolOp):
            old, new = ("and", "or") if isinstance(node.op, ast.And) else ("or", "and")
            span = gap_token(node.values[0], node.values[1], old)
            if span:
                out.append(Mutant(group, path, line, *span, new, f"{old} -> {new}"))
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.Not)):
            a = at(node.lineno, node.col_offset)
            b = at(node.operand.lineno, node.operand.col_offset)
            kind = "drop -" if isinstance(node.op, ast.USub) else "drop not"
            if not isinstance(node.operand, ast.Constant):
                out.append(Mutant(group, path, line, a, b, "", kind))
        elif (isinstance(node, ast.Constant) and isinstance(node.value, (int, float))
              and not isinstance(node.value, bool)):
            a = at(node.lineno, node.col_offset)
            b = at(node.end_lineno or 0, node.end_col_offset or 0)
            value = node.value
            new_value = 1 if value == 0 else value * 2
            out.append(Mutant(group, path, line, a, b, repr(new_value),
                              f"{source[a:b]} -> {new_value!r}"))
    return out


# --- C mutants, from the tokens outside comments, strings and preprocessor lines -----------------

_C_SWAPS = {" + ": " - ", " - ": " + ", " * ": " / ", " / ": " * ", " < ": " <= ",
            " <= ": " < ", " > ": " >= ", " >= ": " > ", " == ": " != ", " != ": " == ",
            " && ": " || ", " || ": " && "}
_C_NUMBER = re.compile(r"(?<![\w.])(\d+\.\d*(?:[eE][-+]?\d+)?|\d+[eE][-+]?\d+|\d+)(?![\w.])")
_C_NEGATION = re.compile(r"(?<=[(=,?:] )-(?=[a-z_(])|(?<=\()-(?=[a-z_(])|(?<=return )-(?=[a-z_(])")


def _mask_c(source: str) -> str:
    """The source with comments, string and character literals and preprocessor lines blanked
    (same length, newlines kept)."""
    def blank(m: re.Match[str]) -> str:
        return re.sub(r"[^\n]", " ", m.group())

    masked = re.sub(r"/\*.*?\*/|//[^\n]*|\"(?:\\.|[^\"\\])*\"|'(?:\\.|[^'\\])'", blank, source,
                    flags=re.DOTALL)
    return re.sub(r"^[ \t]*#[^\n]*(?:\\\n[^\n]*)*", blank, masked, flags=re.MULTILINE)


def c_mutants(group: str, path: str, source: str) -> list[Mutant]:
    masked = _mask_c(source)
    out: list[Mutant] = []

    def line_of(i: int) -> int:
        return source.count("\n", 0, i) + 1

    for old, new in _C_SWAPS.items():
        for m in re.finditer(re.escape(old), masked):
            out.append(Mutant(group, path, line_of(m.start()), m.start(), m.end(), new,
                              f"{old.strip()} -> {new.strip()}"))
    for m in _C_NUMBER.finditer(masked):
        literal = m.group()
        value = float(literal)
        text = "1" if value == 0 and "." not in literal and "e" not in literal.lower() else (
            "1.0" if value == 0 else (str(int(value) * 2) if literal.isdigit() else repr(2 * value)))
        out.append(Mutant(group, path, line_of(m.start()), m.start(), m.end(), text,
                          f"{literal} -> {text}"))
    for m in _C_NEGATION.finditer(masked):
        out.append(Mutant(group, path, line_of(m.start()), m.start(), m.end(), "", "drop -"))
    return sorted(out, key=lambda mu: (mu.start, mu.kind))


@functools.cache
def head_source(path: str) -> str:
    """The file as committed (the copy is HEAD: other work in the working tree is not seen)."""
    return subprocess.run(["git", "-C", str(ROOT), "show", f"HEAD:{path}"], check=True,
                          capture_output=True, text=True).stdout


def mutants_of(group: str, path: str) -> list[Mutant]:
    source = head_source(path)
    if path.endswith((".c", ".h")):
        return c_mutants(group, path, source)
    return python_mutants(group, path, source)


def all_mutants(groups: list[str]) -> dict[str, list[Mutant]]:
    return {g: [m for path in GROUPS[g][0] for m in mutants_of(g, path)] for g in groups}


def sample(mutants: list[Mutant], n: int, seed: int) -> list[Mutant]:
    if n <= 0 or n >= len(mutants):
        return list(mutants)
    chosen = random.Random(seed).sample(range(len(mutants)), n)
    return [mutants[i] for i in sorted(chosen)]


# --- running ----------------------------------------------------------------------------------------

class Copy:
    """A private copy of the repository at HEAD with its own cache folder; deleted on close."""

    def __init__(self) -> None:
        self.folder = Path(tempfile.mkdtemp(prefix="maniplab-mutants-"))
        self.tree = self.folder / "tree"
        self.tree.mkdir()
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", "HEAD"], check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(self.tree)], input=archive, check=True)
        self.cache = self.folder / "cache"
        self.cache.mkdir()
        home = Path(os.environ.get("MANIPLAB_CACHE") or
                    Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "maniplab")
        if home.is_dir():  # the generated models (keyed by their sources, none of them mutated)
            for entry in home.iterdir():
                if entry.is_dir() and re.fullmatch(r"[0-9a-f]{64}", entry.name):
                    shutil.copytree(entry, self.cache / entry.name, dirs_exist_ok=True)

    def run_tests(self, tests: list[str], timeout: float) -> tuple[str, float, str]:
        """('passed' | 'failed' | 'timeout', seconds, the last lines of pytest's output)."""
        env = {**os.environ, "PYTHONPATH": str(self.tree / "src"),
               "MANIPLAB_CACHE": str(self.cache), "PYTHONDONTWRITEBYTECODE": "1"}
        command = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider",
                   "-p", "no:xdist", *tests]
        start = time.monotonic()
        child = subprocess.Popen(command, cwd=self.tree, env=env, stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT, text=True, start_new_session=True)
        try:
            output, _ = child.communicate(timeout=timeout)
            status = "passed" if child.returncode == 0 else "failed"
        except subprocess.TimeoutExpired:
            os.killpg(child.pid, signal.SIGKILL)
            output, _ = child.communicate()
            status = "timeout"
        finally:
            if child.poll() is None:
                os.killpg(child.pid, signal.SIGKILL)
                child.wait()
        tail = "\n".join(output.strip().splitlines()[-3:])
        return status, time.monotonic() - start, tail

    def close(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)


def survivors_of(logs: list[Path], groups: list[str]) -> dict[str, list[Mutant]]:
    """The mutants recorded as survived in earlier results (JSON lines), found again among the
    mutants of HEAD by their place, kind and change."""
    wanted = set()
    for log in logs:
        for line in log.read_text().splitlines():
            d = json.loads(line)
            if d["verdict"] == "survived" and d["group"] in groups:
                wanted.add((d["group"], d["where"], d["kind"], d["change"]))
    out: dict[str, list[Mutant]] = {g: [] for g in groups}
    for group, mutants in all_mutants(groups).items():
        for m in mutants:
            key = (group, f"{m.path}:{m.line}", m.kind, m.describe(head_source(m.path)))
            if key in wanted:
                out[group].append(m)
    return out


def run(groups: list[str], n: int, seed: int, out: Path,
        rerun: list[Path] | None = None) -> int:
    if rerun:
        chosen = survivors_of(rerun, groups)
        groups = [g for g in groups if chosen[g]]
    else:
        chosen = {g: sample(ms, n, seed) for g, ms in all_mutants(groups).items()}
    enumerated = {g: len(ms) for g, ms in all_mutants(groups).items()}
    out.mkdir(parents=True, exist_ok=True)
    log = out / "results.jsonl"
    log.write_text("")
    copy = Copy()
    summary: dict[str, dict[str, int]] = {}
    survivors: list[str] = []
    try:
        for group in groups:
            tests = GROUPS[group][1]
            status, seconds, tail = copy.run_tests(tests, 3600.0)
            if status != "passed":
                raise SystemExit(f"{group}: the unmutated tests fail:\n{tail}")
            timeout = 3.0 * seconds + 60.0
            print(f"{group}: {len(chosen[group])} of {enumerated[group]} mutants, "
                  f"unmutated tests {seconds:.0f} s", flush=True)
            counts = {"enumerated": enumerated[group], "run": 0, "killed": 0, "timeout": 0,
                      "survived": 0}
            for mutant in chosen[group]:
                target = copy.tree / mutant.path
                original = target.read_text()
                assert original == head_source(mutant.path), mutant.path
                try:
                    target.write_text(mutant.apply(original))
                    status, seconds, tail = copy.run_tests(tests, timeout)
                finally:
                    target.write_text(original)
                verdict = {"passed": "survived", "failed": "killed"}.get(status, status)
                counts["run"] += 1
                counts[verdict] += 1
                where = f"{mutant.path}:{mutant.line}"
                what = mutant.describe(original)
                print(f"  {verdict:8s} {seconds:6.1f} s  {where}  {mutant.kind}", flush=True)
                if verdict == "survived":
                    survivors.append(f"| {group} | {where} | {what} |")
                with log.open("a") as f:
                    f.write(json.dumps({"group": group, "where": where, "kind": mutant.kind,
                                        "change": what, "verdict": verdict,
                                        "seconds": round(seconds, 1), "tail": tail}) + "\n")
            summary[group] = counts
    finally:
        copy.close()
        _write_summary(out / "summary.md", summary, survivors, n, seed)
    return 0


def _write_summary(path: Path, summary: dict[str, dict[str, int]], survivors: list[str],
                   n: int, seed: int) -> None:
    lines = [f"sample: {n or 'all'} per group, seed {seed}", "",
             "| group | mutants | run | killed | timeout | survived | kill rate |",
             "|---|---|---|---|---|---|---|"]
    total = {"enumerated": 0, "run": 0, "killed": 0, "timeout": 0, "survived": 0}
    for group, c in summary.items():
        rate = (c["killed"] + c["timeout"]) / c["run"] if c["run"] else float("nan")
        lines.append(f"| {group} | {c['enumerated']} | {c['run']} | {c['killed']} | "
                     f"{c['timeout']} | {c['survived']} | {100 * rate:.0f} % |")
        for k in total:
            total[k] += c[k]
    if total["run"]:
        rate = (total["killed"] + total["timeout"]) / total["run"]
        lines.append(f"| all | {total['enumerated']} | {total['run']} | {total['killed']} | "
                     f"{total['timeout']} | {total['survived']} | {100 * rate:.0f} % |")
    lines += ["", "| group | where | change |", "|---|---|---|", *survivors]
    path.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--groups", default=",".join(GROUPS),
                        help=f"comma-separated, of {', '.join(GROUPS)}")
    parser.add_argument("--sample", type=int, default=DEFAULT_SAMPLE,
                        help="mutants per group, drawn with --seed (0: all)")
    parser.add_argument("--seed", type=int, default=42)
    parser.add_argument("--list", action="store_true", help="list the mutants, run nothing")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "mutants")
    parser.add_argument("--rerun", type=Path, nargs="+", metavar="RESULTS",
                        help="run again the survivors of earlier results.jsonl files (after "
                             "adding tests), instead of a sample")
    args = parser.parse_args(argv)
    groups = [g.strip() for g in args.groups.split(",") if g.strip()]
    unknown = [g for g in groups if g not in GROUPS]
    if unknown:
        parser.error(f"unknown group {unknown[0]!r}; expected one of {', '.join(GROUPS)}")
    if args.list:
        for group, ms in all_mutants(groups).items():
            picked = set(map(id, sample(ms, args.sample, args.seed)))
            for m in ms:
                mark = "*" if id(m) in picked else " "
                source = head_source(m.path)
                print(f"{mark} {group} {m.path}:{m.line} {m.kind}: {m.describe(source)}")
        return 0
    def interrupt(signum: int, _frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, interrupt)  # a kill also deletes the copy
    try:
        return run(groups, args.sample, args.seed, args.out, args.rerun)
    except KeyboardInterrupt:
        print("interrupted: the copy is deleted, the working tree was never touched",
              file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
