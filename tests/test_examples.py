"""The workflow scripts in examples/ run in a short form and produce what they promise."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

import maniplab as ml

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def run(script: str, *args: str) -> str:
    result = subprocess.run([sys.executable, str(EXAMPLES / script), *args], capture_output=True,
                            text=True, timeout=600, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    return result.stdout


@pytest.mark.parametrize("spec", ["crane3", "planar2"])
def test_spec_to_mjcf(tmp_path: Path, spec: str) -> None:
    out = run("spec_to_mjcf.py", spec, "-o", str(tmp_path))
    assert "largest relative difference" in out
    assert float(out.split("bias: ")[1]) < 1e-9
    for name in ("arm.xml", "model.md", "model.py"):
        assert (tmp_path / name).stat().st_size > 100


def test_spec_to_mjcf_with_a_users_file(tmp_path: Path) -> None:
    spec = tmp_path / "mine.yaml"
    ml.builtin_spec("crane3").with_overrides({"end_effector.mass": 250.0}).dump(spec)
    run("spec_to_mjcf.py", str(spec), "-o", str(tmp_path / "out"))
    assert ml.build_model(spec).body_mass.sum() == pytest.approx(
        250.0 + 143.7 + 157.9 + 250.0, rel=1e-9)


def test_parameter_sweep(tmp_path: Path) -> None:
    out = run("parameter_sweep.py", "-o", str(tmp_path), "--duration", "0.5")
    assert len(list((tmp_path / "runs").glob("*.npz"))) == 6
    assert (tmp_path / "sweep.png").stat().st_size > 10_000
    assert out.count("MPa") == 6


def test_make_video(tmp_path: Path) -> None:
    run("make_video.py", "-o", str(tmp_path), "--width", "160", "--height", "96", "--fps", "5",
        "--duration", "1")
    single = np.stack(list(iio.imiter(tmp_path / "erector.mp4")))
    grid = np.stack(list(iio.imiter(tmp_path / "payloads.mp4")))
    assert single.shape == (6, 96, 160, 3) and grid.shape == (6, 96, 160, 3)
    # not blank: the arm's coloured links are drawn (the sky and floor are grey), in both
    # panels of the grid; and the arm moves: the first and last frames differ where it is
    colourful = lambda frames: (frames.max(axis=-1).astype(int) - frames.min(axis=-1)) > 80
    assert colourful(single).sum(axis=(1, 2)).min() > 50
    half = grid.shape[2] // 2
    assert colourful(grid[:, :, :half]).sum() > 50 and colourful(grid[:, :, half:]).sum() > 50
    moved = np.abs(single[-1].astype(int) - single[0].astype(int)).max(axis=-1) > 40
    assert moved.sum() > 20


def test_cylinder_pins_draws_the_pins_and_refuses_a_joint_without_one(tmp_path: Path) -> None:
    spec = "patu655"
    run("cylinder_pins.py", spec, "tilt", "-o", str(tmp_path / "pins.png"))
    assert iio.imread(tmp_path / "pins.png").shape[1] > 800
    result = subprocess.run([sys.executable, str(EXAMPLES / "cylinder_pins.py"), spec, "slew"],
                            capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 2 and "no pinned cylinder" in result.stderr


def test_lowering_oscillation_plots_each_ratio_and_refuses_a_joint_without_a_valve(
        tmp_path: Path) -> None:
    crane = str(Path(__file__).parent / "arms" / "knuckle_crane.yaml")
    out = run("lowering_oscillation.py", crane, "boom", "--ratios", "1", "--command", "-0.15",
              "--start=0,-0.6,1.2,0.5,0", "--duration", "1.0", "-o", str(tmp_path / "low.png"))
    assert "1:1: lowers without oscillating" in out
    assert iio.imread(tmp_path / "low.png").shape[1] >= 700
    result = subprocess.run([sys.executable, str(EXAMPLES / "lowering_oscillation.py"), crane,
                             "telescope", "--command", "-0.1"],
                            capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 2 and "no counterbalance valve" in result.stderr


def test_sway_damping_compares_a_move_with_and_without(tmp_path: Path) -> None:
    crane = str(Path(__file__).parent / "arms" / "grapple_crane.yaml")
    out = run("sway_damping.py", crane, "--start=0,-0.3,1.2,0,0", "--goal", "0.3,-0.3,1.2",
              "--duration", "2", "--settle", "1", "-o", str(tmp_path / "sway.png"))
    assert "without:" in out and "with sway damping:" in out
    assert iio.imread(tmp_path / "sway.png").shape[1] >= 700
    result = subprocess.run([sys.executable, str(EXAMPLES / "sway_damping.py"), "planar2",
                             "--start=0,0", "--goal", "0.1,0.1"],
                            capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 2 and "no passive joints" in result.stderr
