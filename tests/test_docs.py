"""The documentation site: it builds in strict mode, and the examples of its pages run.

The examples are the ``python`` and ``sh`` code blocks of every page under ``docs/``. Each page
runs in a child process (this file run as a script) in a temporary folder of its own, with the
repository's ``src/`` and ``examples/`` linked in as in a checkout: its Python blocks share one
namespace, its shell blocks run with bash (``set -e``) and the environment's ``maniplab`` and
``python`` first on PATH. An HTML comment on the line before a block changes what happens to it:

- ``<!-- docs-test: skip: REASON -->``: shown, not run (the demo, benchmarks, installs, servers);
- ``<!-- docs-test: file NAME -->``: written to the file NAME in the page's folder, not run;
- ``<!-- docs-test: as written: REASON -->``: run as written, not shortened.

Long runs are shortened while ``MANIPLAB_DOCS_QUICK`` is ``1`` (the default; ``0`` runs every
example as written): simulated durations (``--duration T``, ``duration=T``) are capped at
0.5 s, and videos (``maniplab render``, ``width=``, ``height=``) at 320x180 pixels. The switch
is documented on the site's development page.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
BIN = Path(sys.executable).parent  # the environment's bin: its maniplab and python
RUN_LANGS = {"python": "python", "py": "python", "sh": "sh", "bash": "sh", "shell": "sh"}
QUICK_VARIABLE = "MANIPLAB_DOCS_QUICK"
QUICK_DURATION = 0.5  # s: the longest simulated duration of a shortened example
QUICK_FRAME = (320, 180)  # the largest video frame of a shortened example, pixels
MARK = re.compile(r"^<!--\s*docs-test:\s*(?P<what>skip|file|as written)\s*:?\s*(?P<arg>.*?)\s*-->$")
NUMBER = r"(\d+(?:\.\d*)?(?:e-?\d+)?)\b"


@dataclass
class Block:
    """One fenced code block of a page."""

    page: Path
    line: int  # of the opening fence, 1-based
    lang: str
    code: str
    mark: str | None = None  # skip, file, as written
    arg: str = ""

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"

    @property
    def runs(self) -> bool:
        return self.lang in RUN_LANGS and self.mark not in ("skip", "file")


def blocks(page: Path) -> list[Block]:
    """The fenced code blocks of a Markdown page, with the mark on the line before each."""
    found: list[Block] = []
    lines = page.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        opening = re.match(r"^```\s*([\w+-]*)", lines[i])
        if not opening:
            i += 1
            continue
        start = i
        i += 1
        body = []
        while i < len(lines) and lines[i].strip() != "```":
            body.append(lines[i])
            i += 1
        block = Block(page, start + 1, opening.group(1).lower(), "\n".join(body) + "\n")
        previous = lines[start - 1].strip() if start else ""
        mark = MARK.match(previous)
        if mark:
            block.mark, block.arg = mark.group("what"), mark.group("arg")
        found.append(block)
        i += 1
    return found


def pages() -> list[Path]:
    """Every page of the site's source, excluding the build's own code."""
    return sorted(p for p in DOCS.rglob("*.md") if "_hooks" not in p.parts)


def example_pages() -> list[Path]:
    """The pages with at least one example to run."""
    return [p for p in pages() if any(b.runs for b in blocks(p))]


def _capped(limit: float, integer: bool = False) -> Callable[[re.Match[str]], str]:
    """A ``re.sub`` replacement that caps the number in group 2 at ``limit``."""

    def replace(match: re.Match[str]) -> str:
        value = min(float(match.group(2)), limit)
        return match.group(1) + (str(int(value)) if integer else repr(value))
    return replace


def shorten(block: Block, quick: bool) -> str:
    """The block's code, shortened when ``quick``: simulated durations capped at QUICK_DURATION,
    video frames at QUICK_FRAME (a ``maniplab render`` command without a size gets it)."""
    code = block.code
    if not quick or block.mark == "as written":
        return code
    width, height = QUICK_FRAME
    if RUN_LANGS[block.lang] == "python":
        code = re.sub(r"(\bduration=)" + NUMBER, _capped(QUICK_DURATION), code)
        code = re.sub(r"(\bwidth=)" + NUMBER, _capped(width, True), code)
        return re.sub(r"(\bheight=)" + NUMBER, _capped(height, True), code)
    code = re.sub(r"(--duration[ =])" + NUMBER, _capped(QUICK_DURATION), code)
    lines = []
    for line in code.splitlines():
        if re.search(r"\bmaniplab render\b", line):
            command, hash_, comment = line.partition(" #")
            command = re.sub(r"(--width[ =])" + NUMBER, _capped(width, True), command)
            command = re.sub(r"(--height[ =])" + NUMBER, _capped(height, True), command)
            if "--width" not in command:
                command = command.rstrip() + f" --width {width}"
            if "--height" not in command:
                command = command.rstrip() + f" --height {height}"
            line = command + (" " + hash_ + comment if hash_ else "")
        lines.append(line)
    return "\n".join(lines) + "\n"


def quick() -> bool:
    return os.environ.get(QUICK_VARIABLE, "1").strip() != "0"


def run_page(page: Path, folder: Path) -> int:
    """Run the examples of ``page`` in ``folder`` (the child process's job); 0 when all pass."""
    folder.mkdir(parents=True, exist_ok=True)
    for name in ("src", "examples"):
        link = folder / name
        if not link.exists():
            link.symlink_to(ROOT / name, target_is_directory=True)
    os.chdir(folder)
    sys.path.insert(0, str(folder))  # as for a script in this folder: its modules import
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}"}
    namespace: dict[str, object] = {"__name__": "__main__"}
    shortened = quick()
    for block in blocks(page):
        if block.mark == "file":
            (folder / block.arg).write_text(block.code, encoding="utf-8")
            continue
        if not block.runs:
            continue
        code = shorten(block, shortened)
        started = time.perf_counter()
        if RUN_LANGS[block.lang] == "python":
            try:
                exec(compile(code, block.where, "exec"), namespace)  # noqa: S102 - the page's own example
            except BaseException as exc:  # noqa: BLE001 - report which block failed
                import traceback

                traceback.print_exc()
                print(f"\nFAILED {block.where} (python): {exc.__class__.__name__}: {exc}")
                return 1
        else:
            result = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", code], env=env,
                                    cwd=folder, capture_output=True, text=True, check=False)
            if result.returncode != 0:
                print(result.stdout[-4000:], result.stderr[-4000:], sep="\n")
                print(f"\nFAILED {block.where} (sh), exit status {result.returncode}:\n{code}")
                return 1
        print(f"ok {block.where} ({block.lang}, {time.perf_counter() - started:.1f} s)",
              flush=True)
    return 0


# --- the tests ---------------------------------------------------------------------------------

def test_site_builds_in_strict_mode(tmp_path: Path) -> None:
    """``mkdocs build --strict``: a broken link or anchor, a page missing from the navigation, an
    unknown ``:::`` reference or a docstring griffe cannot parse fails the build."""
    site = tmp_path / "site"
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(site)], cwd=ROOT,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"}, capture_output=True, text=True,
        timeout=600, check=False)
    output = result.stdout + result.stderr
    warnings = [line for line in output.splitlines() if line.startswith(("WARNING", "ERROR"))]
    assert result.returncode == 0, "the strict build failed:\n" + ("\n".join(warnings) or output)
    cli = (site / "reference" / "cli.html").read_text(encoding="utf-8")
    for command in ("simulate", "sweep", "control", "render", "demo"):
        assert f"usage: maniplab {command}" in cli, command  # generated from the parsers
    assert "ActuatorPlugin" in (site / "reference" / "api" / "actuators.html").read_text(
        encoding="utf-8")


def test_marks_are_well_formed() -> None:
    """A skipped block says why; a file mark names the file; no mark is misspelt."""
    for page in pages():
        text = page.read_text(encoding="utf-8")
        for line in text.splitlines():
            if line.lstrip().startswith("<!--") and "docs-test" in line:
                assert MARK.match(line.strip()), f"{page.relative_to(ROOT)}: bad mark {line!r}"
        for block in blocks(page):
            if block.mark in ("skip", "as written"):
                assert len(block.arg) > 10, f"{block.where}: a {block.mark} mark needs a reason"
            if block.mark == "file":
                assert re.fullmatch(r"[\w.-]+", block.arg), f"{block.where}: file name"


def test_examples_are_shortened_by_the_switch() -> None:
    block = Block(DOCS / "x.md", 1, "sh", "maniplab simulate a --duration 3 -o b\n"
                  "maniplab render b -o c.mp4 --width 480   # a look\n")
    assert shorten(block, True) == ("maniplab simulate a --duration 0.5 -o b\n"
                                    "maniplab render b -o c.mp4 --width 320 --height 180  # a look\n")
    assert shorten(block, False) == block.code
    block = Block(DOCS / "x.md", 1, "python", "ml.simulate(s, duration=10.0, dt=1e-3)\n"
                  "ml.render(run, width=1280, height=100)\n")
    assert shorten(block, True) == ("ml.simulate(s, duration=0.5, dt=1e-3)\n"
                                    "ml.render(run, width=320, height=100)\n")
    block.mark = "as written"
    assert shorten(block, True) == block.code


def test_pages_run_their_examples_somewhere() -> None:
    """The user guide, the tutorial and the how-to pages all have examples that run."""
    running = {p.relative_to(DOCS).as_posix() for p in example_pages()}
    for page in ("tutorial.md", "guide/spec.md", "guide/simulating.md", "guide/control.md",
                 "guide/videos.md", "howto/new-arm.md", "howto/actuator-plugin.md",
                 "howto/cluster-sweeps.md"):
        assert page in running, page


@pytest.mark.parametrize("page", example_pages(),
                         ids=lambda page: page.relative_to(DOCS).as_posix())
def test_page_examples_run(page: Path, tmp_path: Path) -> None:
    """Every example of the page runs (in a child process, in a folder of its own)."""
    env = {**os.environ, "MPLBACKEND": "Agg"}
    env.setdefault(QUICK_VARIABLE, "1")
    result = subprocess.run([sys.executable, __file__, str(page), str(tmp_path / "work")],
                            env=env, capture_output=True, text=True, timeout=900, check=False)
    assert result.returncode == 0, result.stdout[-8000:] + result.stderr[-4000:]


def test_spec_page_example_is_a_valid_spec(tmp_path: Path) -> None:
    """The spec page's example (formerly the README's) loads and describes what the page says."""
    import maniplab as ml

    example = next(b for b in blocks(DOCS / "guide" / "spec.md") if b.lang == "yaml")
    path = tmp_path / "two-link.yaml"
    path.write_text(example.code)
    spec = ml.load_spec(path)
    assert spec.joint_names == ("q1", "q2")
    assert spec.joint("q2").actuator.type == "hydraulic"
    assert spec.joint("q2").body.com == (0.5, 0.0, 0.0)  # default: middle of a 1 m body


def test_control_page_shows_the_defaults(tmp_path: Path) -> None:
    """The control page's ``control:`` block is the controller's defaults."""
    import maniplab as ml

    example = next(b for b in blocks(DOCS / "guide" / "control.md")
                   if b.lang == "yaml" and b.code.startswith("control:"))
    path = tmp_path / "arm.yaml"
    path.write_text("name: arm\njoints:\n  - {type: R, axis: z, body: {length: 1.0, mass: 1.0}}\n"
                    + example.code)
    assert ml.load_spec(path).control == ml.ControlSpec()


def test_module_map_lists_every_module() -> None:
    """The development page's module map has one line per module of src/maniplab, no more."""
    text = (DOCS / "about" / "development.md").read_text(encoding="utf-8")
    listed = re.findall(r"^\| `(maniplab[\w.]*)` \|", text, re.MULTILINE)
    src = ROOT / "src"
    modules = {".".join(p.relative_to(src).with_suffix("").parts).removesuffix(".__init__")
               for p in (src / "maniplab").rglob("*.py")}
    assert len(listed) == len(set(listed)), "a module is listed twice"
    missing, gone = sorted(modules - set(listed)), sorted(set(listed) - modules)
    assert not missing, f"add these modules to the module map of docs/about/development.md: {missing}"
    assert not gone, f"the module map of docs/about/development.md lists missing modules: {gone}"


if __name__ == "__main__":  # the child process of test_page_examples_run
    sys.exit(run_page(Path(sys.argv[1]).resolve(), Path(sys.argv[2]).resolve()))
