"""Comparison plots: the lines are the runs' data in display units, the legend names what differs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import maniplab as ml
from maniplab.sim import Run
from maniplab.viz.plots import PlotError, compare, save_figure


def runs() -> list[Run]:
    base = ml.builtin_spec("erector")
    out = []
    t = np.linspace(0.0, 2.0, 50)
    for k, mass in enumerate((3000.0, 4000.0)):
        spec = base.with_overrides({"end_effector.mass": mass})
        q = np.outer(np.sin(t), np.arange(1, 7)) * (k + 1)
        dp = np.full((50, 6), 2.0e6 * (k + 1))
        ee = np.c_[np.cos(t), np.sin(t), np.zeros_like(t)]
        out.append(Run(t, {"q": q, "dP": dp, "mode": (q > 0.5).astype(int), "ee_pos": ee}, spec))
    return out


def test_lines_are_the_data_in_display_units() -> None:
    fig = compare(runs(), signals=["q", "dP"], joints=["q2", "q4"])
    axes = fig.axes
    assert len(axes) == 4
    q2 = axes[0].get_lines()
    assert np.array_equal(q2[1].get_ydata(), runs()[1].q[:, 1])
    dp_q4 = axes[3].get_lines()
    assert np.allclose(dp_q4[0].get_ydata(), 2.0)  # 2 MPa
    assert axes[3].get_ylabel() == "ΔP [MPa]"
    assert axes[1].get_ylabel() == "position [m]"  # q4 is prismatic
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend == ["payload=3000", "payload=4000"]


def test_end_effector_path_uses_the_two_moving_axes() -> None:
    fig = compare(runs(), signals=["ee_path"])
    ax = fig.axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x [m]", "y [m]")


@pytest.mark.parametrize("suffix, magic", [(".png", b"\x89PNG"), (".svg", b"<?xml"), (".pdf", b"%PDF")])
def test_save_formats(tmp_path: Path, suffix: str, magic: bytes) -> None:
    path = save_figure(compare(runs(), signals=["q"]), tmp_path / f"fig{suffix}")
    assert path.read_bytes().startswith(magic)
    assert [p.name for p in tmp_path.iterdir()] == [f"fig{suffix}"]


def test_bad_requests_are_clear() -> None:
    with pytest.raises(PlotError, match="no signal 'Q'"):
        compare(runs(), signals=["Q"])
    with pytest.raises(ml.SpecError, match="no joint 'q9'"):
        compare(runs(), signals=["q"], joints=["q9"])
    with pytest.raises(PlotError, match="unknown figure format"):
        save_figure(compare(runs()), "fig.jpg")


def test_the_video_strip_shows_the_figures_units_and_its_labels_minus_signs() -> None:
    """The strip under a video shows ΔP in MPa as the figures do, and its axis labels fit in the
    margin: the left-most pixel column stays background (a clipped '-18' would read '18')."""
    from maniplab.viz.plot_strip import PlotStrip, select

    t = np.linspace(0.0, 1.0, 40)
    spec = ml.builtin_spec("crane3")
    dp = np.outer(np.linspace(-1.8e7, 1.56e7, 40), np.ones(spec.n))
    run = Run(t, {"q": np.zeros((40, spec.n)), "dP": dp}, spec)
    curves, title = select([run], "dP:luff")
    assert title == "dP:luff [MPa]"
    np.testing.assert_allclose(curves[0].y, dp[:, 1] / 1e6)
    assert select([run], "q")[1] == "q [rad | m]"  # crane3 has rotational and prismatic joints
    strip = PlotStrip(curves, title, 320, 60, 0.0, 1.0)
    background = strip.bright[strip.height // 2, strip.left + 2]  # inside the plot, off the curve
    assert (strip.bright[:, 0] == background).all()
    assert not (strip.bright[:, 1:strip.left - 3] == background).all()  # the labels are drawn


def test_runs_that_agree_stay_visible_on_top_of_each_other() -> None:
    """Two equal runs (a cross-validation that agrees) draw distinct line styles, so the second
    does not hide the first."""
    run = runs()[0]
    fig = compare([run, run], signals=["q"], joints=["q2"])
    lines = fig.axes[0].get_lines()
    np.testing.assert_array_equal(lines[0].get_ydata(), lines[1].get_ydata())
    assert lines[0].get_linestyle() != lines[1].get_linestyle()
    assert lines[0].get_color() != lines[1].get_color()
