"""The README's example spec is a valid spec and describes what the README says."""

from __future__ import annotations

import re
from pathlib import Path

import maniplab as ml

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_example_spec_loads(tmp_path: Path) -> None:
    block = re.search(r"```yaml\n(.*?)```", README.read_text(), re.DOTALL)
    assert block, "README has no yaml example"
    path = tmp_path / "two-link.yaml"
    path.write_text(block.group(1))
    spec = ml.load_spec(path)
    assert spec.joint_names == ("q1", "q2")
    assert spec.joint("q2").actuator.type == "hydraulic"
    assert spec.joint("q2").body.com == (0.5, 0.0, 0.0)  # default: middle of a 1 m body
