"""``maniplab demo --quick``: every artefact exists and is non-empty, and the report shows what the
runs produced (its images are the written figures, its numbers follow from the stored runs)."""

from __future__ import annotations

import base64
import json
import re
import subprocess
import sys
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

import maniplab as ml

ARTEFACTS = [
    "erector.xml", "model/erector_model.md", "model/erector_model.py", "open_loop_step.png",
    "open_loop_impulse.png", "open_loop_sine.png", "closed_loop.png", "crossval.png",
    "closed_loop.mp4", "cascade_vs_pid.mp4", "closed_loop_frame.png",
    "cascade_vs_pid_frame.png", "summary.json", "closed_loop_replay.html",
    "report.html", "runs/closed_loop_cascade.npz", "runs/closed_loop_pid.npz",
]


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    out = tmp_path_factory.mktemp("demo")
    result = subprocess.run([sys.executable, "-m", "maniplab", "demo", "--quick", "-o", str(out)],
                            capture_output=True, text=True, timeout=600, check=False)
    assert result.returncode == 0, result.stderr
    return out, result.stdout


def test_every_artefact_exists_and_is_not_empty(demo) -> None:
    out, _ = demo
    for name in ARTEFACTS:
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    for name in ("step", "impulse", "sine"):
        assert len(list((out / "runs" / name).glob("*.npz"))) == 6


def test_terminal_shows_a_line_per_stage_and_the_report(demo) -> None:
    out, stdout = demo
    stages = re.findall(r"^\[(\d)/7\] .* done", stdout, re.MULTILINE)
    assert stages == [str(k) for k in range(1, 8)]
    assert stdout.rstrip().endswith(f"report: {(out / 'report.html').resolve()}")


def test_report_embeds_exactly_the_written_figures(demo) -> None:
    out, _ = demo
    html = (out / "report.html").read_text()
    embedded = [base64.b64decode(data) for data in re.findall(r"data:image/png;base64,([^'\"]+)", html)]
    written = {p.name: p.read_bytes() for p in out.glob("*.png")}
    assert len(embedded) == len(written)  # every figure once; the video frame as the poster
    assert sorted(embedded) == sorted(written.values())
    for video in ("closed_loop.mp4", "cascade_vs_pid.mp4"):  # each previewed by its last frame
        assert f"href='{video}'><img src='data:image/png;base64," in html
        assert f"alt='last frame of {video}'" in html
    last = iio.imread(out / "cascade_vs_pid.mp4")[-1]
    poster = iio.imread(out / "cascade_vs_pid_frame.png")
    assert last.shape == poster.shape and np.abs(last.astype(int) - poster).mean() < 8  # H.264


def test_report_embeds_the_3d_replay_of_the_closed_loop_runs(demo) -> None:
    """The report holds the replay page itself (inline, so it works offline) and links it; the
    page's recording holds both runs' arms (the cascade solid, the PID run a ghost)."""
    import html as html_module

    out, _ = demo
    report = (out / "report.html").read_text()
    page = (out / "closed_loop_replay.html").read_text()
    frames = re.findall(r"<iframe class='replay' title='([^']+)' srcdoc='([^']*)'>", report)
    assert [(name, html_module.unescape(doc)) for name, doc in frames] == \
        [("closed_loop_replay.html", page)]
    assert "href='closed_loop_replay.html'" in report
    assert "window.maniplabPlayer" in page and "http://" not in page.lower()


def test_reported_tracking_error_follows_from_the_stored_run(demo) -> None:
    out, _ = demo
    summary = json.loads((out / "summary.json").read_text())
    html = (out / "report.html").read_text()
    move = summary["closed_loop"].pop("move")
    for figures in summary["closed_loop"].values():
        run = ml.Run.load(out / figures["run"])
        t0, t1 = figures["window_s"]
        inside = (run.t >= t0) & (run.t <= t1)
        # the minimum-jerk reference in closed form: s(τ) = 10τ³ - 15τ⁴ + 6τ⁵
        tau = np.clip((run.t[inside] - move["t0_s"]) / move["duration_s"], 0.0, 1.0)
        s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
        start, goal = np.array(move["start_m"]), np.array(move["goal_m"])
        reference = start + s[:, None] * (goal - start)
        error = np.linalg.norm(reference - run["ee_pos"][inside], axis=1)
        rms_mm = 1e3 * np.sqrt(np.mean(error**2))
        assert rms_mm == pytest.approx(figures["rms_error_mm"], rel=0.02)
        assert f"{figures['rms_error_mm']:.2f} / " in html
    assert summary["closed_loop"]["pid"]["rms_error_mm"] > summary["closed_loop"]["cascade"]["rms_error_mm"]


def test_videos_have_the_quick_size_and_move(demo) -> None:
    out, _ = demo
    frames = iio.imread(out / "closed_loop.mp4", plugin="pyav") if _has_pyav() else \
        np.stack(list(iio.imiter(out / "closed_loop.mp4")))
    assert frames.shape[1:] == (180, 320, 3)
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).mean() > 0.5


def test_crossval_agreement_is_reported(demo) -> None:
    out, _ = demo
    summary = json.loads((out / "summary.json").read_text())
    assert summary["crossval"]["max_deviation"] < 1e-4
    assert f"{summary['crossval']['max_deviation']:.2e} rad" in (out / "report.html").read_text()


def _has_pyav() -> bool:
    try:
        import av  # noqa: F401
    except ImportError:
        return False
    return True
