"""The README is the front door: short, its two commands as they are, every link and image it
has pointing into the repository, and every headline figure linked to its benchmark page.

(The example spec it used to carry is on the site's spec page now; tests/test_docs.py checks it
there.)"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
TWO_COMMANDS = """```sh
make demo    # creates .venv, installs maniplab, runs the main job on the built-in erector
make test    # the same set-up, then the whole test suite
```"""


def section(title: str) -> str:
    text = README.read_text(encoding="utf-8")
    match = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", text, re.DOTALL | re.MULTILINE)
    assert match, f"README has no section {title!r}"
    return match.group(1)


def test_readme_is_a_front_door() -> None:
    lines = README.read_text(encoding="utf-8").splitlines()
    assert 150 <= len(lines) < 250, len(lines)
    assert TWO_COMMANDS in section("The two commands")
    for title in ("Gallery", "Five-minute tutorial: from your own spec to a validated controller",
                  "Documentation", "Headline figures"):
        section(title)


def test_links_and_images_point_into_the_repository() -> None:
    text = README.read_text(encoding="utf-8")
    targets = re.findall(r"\]\(([^)\s]+)\)", text)
    local = [t for t in targets if not re.match(r"[a-z]+://", t)]
    assert len(local) > 20
    for target in local:
        path = (ROOT / target.split("#")[0]).resolve()
        assert path.is_relative_to(ROOT), f"{target} points outside the repository"
        assert path.exists(), f"README links to {target}, which does not exist"
    for image in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text):
        assert image.startswith("docs/img/") and (ROOT / image).is_file(), image


def test_nothing_points_outside_the_repository() -> None:
    """No page, spec, module, test or benchmark refers to the developers' notes beside the
    repository (a user does not have them)."""
    sources = [p for folder in ("src", "tests", "benchmarks", "examples", "docs")
               for p in (ROOT / folder).rglob("*")
               if p.suffix in {".md", ".py", ".yaml", ".c", ".h"} and "__pycache__" not in p.parts]
    assert len(sources) > 100
    for path in [README, ROOT / "mkdocs.yml", *sources]:
        text = path.read_text(encoding="utf-8")
        if path.name == "test_readme.py":
            continue
        for marker in ("../shared", "shared/", "REFERENCES", "DESIGN.md"):
            assert marker not in text, f"{path} mentions {marker}"


def test_headline_figures_link_to_their_benchmark_pages() -> None:
    rows = [line for line in section("Headline figures").splitlines()
            if line.startswith("| [")]
    assert len(rows) >= 6
    for row in rows:
        link = re.match(r"\| \[[^\]]+\]\((docs/benchmarks/\w+\.md)\)", row)
        assert link, f"headline figure without its benchmark page: {row}"
        page = (ROOT / link.group(1)).read_text(encoding="utf-8")
        assert "python benchmarks/" in page, f"{link.group(1)} gives no command to reproduce it"


def test_the_license_is_an_spdx_expression() -> None:
    """A license table is deprecated (setuptools warns on every install); PEP 639's string is
    not, and a build backend that reads it is required."""
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert project["project"]["license"] == "Apache-2.0"
    requires = project["build-system"]["requires"]
    assert any(r.startswith("setuptools>=") and int(r.split(">=")[1].split(".")[0]) >= 77
               for r in requires)
