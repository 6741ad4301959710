"""Rendered videos: frame count and size read back from the file, frames follow the motion, grid
tiles equal single renders, joint-state colours exactly where the run has the state, the CLI.

These tests need an OpenGL backend: ``MUJOCO_GL`` as set, else ``egl`` (Mesa's software renderer
runs without display or GPU). Where none can start they are skipped with the reason. Frames are
small (160x120) and runs short, so the module takes seconds.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import imageio.v3 as iio
import mujoco
import numpy as np
import pytest

import maniplab as ml
from maniplab import viz
from maniplab.cli import main
from maniplab.friction.modes import FrictionMode
from maniplab.sim.run import Run
from maniplab.viz.gl import RenderError
from maniplab.viz.render import strip_height

RATE = 100.0  # samples per second of the hand-made runs
W, H = 160, 120


pytestmark = pytest.mark.usefixtures("offscreen_gl")


def scripted(spec_name: str, q_of_t, duration: float, *, modes: dict | None = None,
             overrides: dict | None = None, label: str | None = None) -> Run:
    """A run of a built-in arm following ``q_of_t(t) -> (N, n)``, with modes set by hand.

    ``modes`` maps a joint index to a list of (t_start, t_end, FrictionMode) held on [start, end).
    """
    spec = ml.builtin_spec(spec_name)
    if overrides:
        spec = spec.with_overrides(overrides)
    t = np.arange(round(duration * RATE) + 1) / RATE
    q = q_of_t(t)
    mode = np.full(q.shape, int(FrictionMode.SLIP))
    for joint, spans in (modes or {}).items():
        for start, end, value in spans:
            mode[(t >= start - 1e-9) & (t < end - 1e-9), joint] = int(value)
    meta = {"label": label} if label else {}
    return Run(t=t, signals={"q": q, "qd": np.gradient(q, t, axis=0), "mode": mode}, spec=spec,
               meta=meta)


def planar_wave(t: np.ndarray) -> np.ndarray:
    """Both joints move on [0, 1), rest on [1, 2], move again after 2 s."""
    s = np.clip(t, None, 1.0) + np.clip(t - 2.0, 0.0, None)
    return np.column_stack([0.8 * np.sin(1.5 * s), 0.6 * np.sin(2.0 * s)])


def erector_wave(t: np.ndarray) -> np.ndarray:
    q = np.zeros((len(t), 6))
    q[:, 0] = 0.3 * np.sin(t)
    q[:, 1] = 0.4 * np.sin(1.5 * t)
    return q


def blue(frame: np.ndarray) -> int:
    """Pixels of the STICK colour (saturated blue, any shade) in ``frame``."""
    r, g, b = (frame[..., c].astype(int) for c in range(3))
    return int(np.count_nonzero((b >= 60) & (b > 1.6 * g) & (b > 2.5 * r)))


def red(frame: np.ndarray) -> int:
    """Pixels of the joint-limit colour (saturated red, any shade) in ``frame``."""
    r, g, b = (frame[..., c].astype(int) for c in range(3))
    return int(np.count_nonzero((r >= 60) & (r > 2.5 * g) & (r > 2.5 * b)))


# --- one run ------------------------------------------------------------------------------------


def test_mp4_and_gif_read_back_with_the_expected_frames_and_size(tmp_path: Path) -> None:
    run = scripted("planar2", planar_wave, 2.0)
    frames = ml.render(run, width=W, height=H, fps=10)
    assert frames.shape == (21, H, W, 3) and frames.dtype == np.uint8  # 0, 0.1, ..., 2.0 s
    for name in ("a.mp4", "a.gif"):
        path = ml.write_video(frames, tmp_path / name, fps=10)
        video = iio.imread(path, plugin="FFMPEG") if name.endswith(".mp4") else iio.imread(path)
        assert video.shape == (21, H, W, 3)
        assert np.mean(np.abs(video.astype(int) - frames)) < 6  # the same pictures, compressed
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif", "a.mp4"]  # no temporary left


def test_frames_change_while_the_arm_moves_and_stay_identical_while_it_rests() -> None:
    run = scripted("planar2", planar_wave, 3.0)
    frames = ml.render(run, width=W, height=H, fps=10, text=False)
    assert len(frames) == 31
    moving = list(range(10)) + list(range(20, 30))
    for k in moving:
        assert not np.array_equal(frames[k], frames[k + 1]), f"frames {k} and {k + 1}"
    for k in range(10, 20):  # t = 1.0 ... 2.0 s: at rest (the path does not grow either)
        assert np.array_equal(frames[k], frames[k + 1]), f"frames {k} and {k + 1}"


def test_time_stamp_changes_every_frame_at_rest() -> None:
    run = scripted("planar2", lambda t: np.zeros((len(t), 2)), 0.3)
    frames = ml.render(run, width=W, height=H, fps=10)
    assert all(not np.array_equal(a, b) for a, b in itertools.pairwise(frames))


def test_stick_and_limit_colours_appear_exactly_where_the_run_has_those_states() -> None:
    stick, upper = FrictionMode.STICK, FrictionMode.AT_UPPER
    run = scripted("erector", erector_wave, 3.0, modes={
        1: [(0.5, 1.0, stick), (2.2, 2.5, stick)],  # q2, the elbow
        0: [(1.4, 1.6, stick)],  # q1, the shoulder
        2: [(1.8, 2.1, upper)],  # q3 held at its upper limit
    })
    fps = 20
    frames = ml.render(run, width=W, height=H, fps=fps, text=False)
    sample = np.rint(np.arange(len(frames)) / fps * RATE).astype(int)  # the sample each frame shows
    modes = run["mode"][sample]
    sticks = np.any(modes == int(stick), axis=1)
    at_limit = np.any(modes == int(upper), axis=1)
    assert sticks.sum() == 20 and at_limit.sum() == 6  # the test exercises both ways
    assert [blue(f) > 0 for f in frames] == sticks.tolist()
    assert [red(f) > 0 for f in frames] == at_limit.tolist()


def test_named_cameras_and_plot_strip() -> None:
    run = scripted("planar2", planar_wave, 1.0)
    for camera in ("track", "overview"):
        assert ml.render(run, width=W, height=H, fps=5, camera=camera).shape == (6, H, W, 3)
    smooth, jagged = (ml.render(run, width=W, height=H, fps=5, antialias=a) for a in (True, False))
    assert not np.array_equal(smooth, jagged) and np.mean(np.abs(smooth - jagged.astype(int))) < 3
    frames = ml.render(run, width=W, height=H, fps=5, plot="q:q2")
    strip = frames[:, H - strip_height(H, "q"):]
    assert not np.array_equal(strip[0], strip[-1])  # the cursor moves
    with pytest.raises(RenderError, match="unknown camera 'side'.*track, overview"):
        ml.render(run, width=W, height=H, camera="side")
    with pytest.raises(RenderError, match="no such signal"):
        ml.render(run, width=W, height=H, plot="dP")


def test_iter_frames_streams_the_same_frames() -> None:
    run = scripted("planar2", planar_wave, 0.5)
    stream = viz.iter_frames(run, width=W, height=H, fps=10)
    assert len(stream) == 6
    assert np.array_equal(np.stack(list(stream)), ml.render(run, width=W, height=H, fps=10))


# --- comparisons --------------------------------------------------------------------------------


def two_variants() -> list[Run]:
    return [scripted("planar2", planar_wave, 1.0),
            scripted("planar2", lambda t: -0.5 * planar_wave(t), 1.0,
                     overrides={"end_effector.mass": 20.0})]


def test_grid_tiles_equal_single_renders_and_survive_encoding(tmp_path: Path) -> None:
    runs, fps, width, height = two_variants(), 10, 320, 160
    grid = viz.render_grid(runs, width=width, height=height, fps=fps, cols=2)
    layout = viz.grid_layout(2, width, height, cols=2)
    framing = viz.frame_runs(runs, fps)
    singles = [ml.render(run, width=layout.tile_width, height=layout.tile_height, fps=fps,
                         camera=framing, text=False) for run in runs]
    tiles = []
    for k in range(2):
        x, y = layout.view_origin(k)
        tiles.append(grid[:, y:y + layout.tile_height, x:x + layout.tile_width])
        assert np.array_equal(tiles[k], singles[k])
    assert not np.array_equal(singles[0], singles[1])
    video = iio.imread(ml.write_video(grid, tmp_path / "grid.mp4", fps=fps), plugin="FFMPEG")
    for k in range(2):
        x, y = layout.view_origin(k)
        tile = video[:, y:y + layout.tile_height, x:x + layout.tile_width].astype(int)
        own, other = (np.mean(np.abs(tile - singles[j])) for j in (k, 1 - k))
        assert own < 3 and other > 2 * own


def test_grid_with_a_named_camera_uses_each_arms_camera() -> None:
    runs = two_variants()
    grid = viz.render_grid(runs, width=320, height=160, fps=5, camera="overview", text=False,
                           cols=2)
    layout = viz.grid_layout(2, 320, 160, cols=2, text_bar=False)
    x, y = layout.view_origin(1)
    single = ml.render(runs[1], width=layout.tile_width, height=layout.tile_height, fps=5,
                       camera="overview", text=False)
    assert np.array_equal(grid[:, y:y + layout.tile_height, x:x + layout.tile_width], single)


def test_grid_layout_gives_the_arms_the_most_room() -> None:
    wide, tall = 2.0, 0.5  # motions twice as wide as high, or half
    assert viz.grid_layout(4, 1280, 720, aspect=wide).cols == 2  # 2x2 tiles of 640x310
    assert viz.grid_layout(4, 1280, 720, aspect=tall).cols == 4  # 4x1 tiles of 320x654
    assert viz.grid_layout(2, 1280, 720).cols == 2
    with pytest.raises(RenderError, match="do not fit"):
        viz.grid_layout(1000, 320, 160)


def test_captions_name_the_differing_parameters() -> None:
    runs = two_variants()
    assert viz.captions(runs) == ["payload=0", "payload=20"]
    same = [scripted("planar2", planar_wave, 0.2, label=name) for name in ("a", "b")]
    assert viz.captions(same) == ["a", "b"]


def test_overlay_draws_the_variants_as_ghosts_in_their_colours() -> None:
    runs = two_variants()
    overlay = viz.render_overlay(runs, width=W, height=H, fps=5, text=False)
    single = ml.render(runs[0], width=W, height=H, fps=5, camera=viz.frame_runs(runs, 5),
                       text=False)
    assert overlay.shape == single.shape == (6, H, W, 3)
    teal = viz.palette.run_colour(1)

    def tinted(frame: np.ndarray) -> int:  # the ghost's teal, blended at 35 % over anything
        r, g, b = (frame[..., c].astype(int) for c in range(3))
        return int(np.count_nonzero((g > r + 40) & (b > r + 40) & (np.abs(g - b) < 0.2 * g)))

    assert teal[1] > teal[0] and all(tinted(f) > 50 for f in overlay)
    assert sum(tinted(f) for f in single) < 5  # an antialiased edge at most


# --- command line -------------------------------------------------------------------------------


def test_cli_renders_one_run_and_a_grid(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    paths = []
    for k, run in enumerate(two_variants()):
        paths.append(tmp_path / f"run{k}.npz")
        run.save(paths[-1])
    size = ["--width", str(W), "--height", str(H), "--fps", "5"]
    assert main(["render", str(paths[0]), "-o", str(tmp_path / "a.mp4"), *size]) == 0
    assert "wrote" in capsys.readouterr().out
    assert iio.imread(tmp_path / "a.mp4", plugin="FFMPEG").shape == (6, H, W, 3)
    assert main(["render", *map(str, paths), "--grid", "-o", str(tmp_path / "g.gif"),
                 "--width", "320", "--height", "160", "--fps", "5", "--plot", "q:q1"]) == 0
    assert iio.imread(tmp_path / "g.gif").shape == (6, 160, 320, 3)


@pytest.mark.parametrize(("extra", "message"), [
    (["--camera", "side"], "unknown camera 'side'"),
    (["--width", "161"], "even width and height"),
    (["-o", "a.avi"], "unknown video format '.avi'"),
    (["--plot", "dP"], "no such signal"),
])
def test_cli_bad_input_is_one_line_and_status_2(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                               extra: list[str], message: str) -> None:
    path = tmp_path / "run.npz"
    scripted("planar2", planar_wave, 0.2).save(path)
    args = ["render", str(path), "-o", str(tmp_path / "a.mp4"), "--width", "160", "--height", "120",
            *extra]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and err.startswith("maniplab render: ")
    assert not any(p.suffix in (".mp4", ".avi") for p in tmp_path.iterdir())


def test_cli_needs_grid_or_overlay_for_several_runs(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    paths = []
    for k, run in enumerate(two_variants()):
        paths.append(str(tmp_path / f"run{k}.npz"))
        run.save(paths[-1])
    assert main(["render", *paths, "-o", str(tmp_path / "x.mp4")]) == 2
    assert "add --grid or --overlay" in capsys.readouterr().err


def test_a_pinned_cylinder_is_drawn_between_its_pins() -> None:
    """A pinned cylinder is in the scene as a barrel and a rod on the line between its pins (where
    MuJoCo puts the two sites at that pose), the barrel from the parent pin and the rod ending at
    the child pin, in their colours, at every frame; its tendon's own line is not drawn."""
    from maniplab.viz.cylinders import BARREL, ROD
    from maniplab.viz.look import Look
    from maniplab.viz.render import SingleRun

    spec = ml.builtin_spec("patu655")
    t = np.arange(51) / RATE
    q = np.column_stack([0.3 * t, -0.5 + 0.4 * t, 0.4 + 1.0 * t])
    nan = np.full(q.shape, np.nan)
    run = Run(t, {"q": q, "qd": np.zeros_like(q), "dP": nan, "Q": nan,
                  "mode": np.zeros(q.shape, dtype=np.int8)}, spec)
    single = SingleRun(run, W, H, 20.0, Look("auto", False, False, False, False, None))
    arm, view = single.view.arms[0], single.view
    for k in range(len(single.times)):
        view.frame(k)
        scene = view.scene
        geoms = [scene.geoms[i] for i in range(scene.ngeom)]
        assert not [g for g in geoms if g.objtype == mujoco.mjtObj.mjOBJ_TENDON]
        parts = [g for g in geoms if g.type == mujoco.mjtGeom.mjGEOM_CYLINDER
                 and g.objtype == mujoco.mjtObj.mjOBJ_UNKNOWN]
        assert len(parts) == 4
        for barrel, rod, joint in zip(parts[0::2], parts[1::2], ("lift", "tilt")):
            base, tip = (arm.data.site(f"{joint}/cylinder_{end}").xpos for end in ("base", "rod"))
            axis = (tip - base) / np.linalg.norm(tip - base)
            for part, end, sign, colour in ((barrel, base, 1.0, BARREL), (rod, tip, -1.0, ROD)):
                along = part.mat.reshape(3, 3)[:, 2]
                assert along == pytest.approx(sign * axis, abs=1e-6)
                assert part.pos - part.size[2] * along == pytest.approx(end, abs=1e-5)
                assert part.rgba == pytest.approx(colour, abs=1e-6)
    view.close()
