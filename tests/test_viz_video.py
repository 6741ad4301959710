"""write_video: MP4 and GIF through the imageio-ffmpeg binary, atomic, clear errors (no OpenGL)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

import maniplab as ml
from maniplab.viz.gl import RenderError


def ramp(count: int, height: int = 48, width: int = 64) -> np.ndarray:
    """Frames that brighten with the frame index; uint8, shape (count, height, width, 3)."""
    levels = np.linspace(20, 235, count).astype(np.uint8)
    return np.broadcast_to(levels[:, None, None, None], (count, height, width, 3)).copy()


@pytest.mark.parametrize("name", ["clip.mp4", "clip.gif", "CLIP.MP4"])
def test_written_video_reads_back_frame_for_frame(tmp_path: Path, name: str) -> None:
    frames = ramp(12)
    path = ml.write_video(frames, tmp_path / "sub" / name, fps=12)
    assert path == tmp_path / "sub" / name
    video = iio.imread(path, plugin="FFMPEG") if path.suffix.lower() == ".mp4" else iio.imread(path)
    assert video.shape == frames.shape
    assert np.max(np.abs(video.mean(axis=(1, 2, 3)) - frames.mean(axis=(1, 2, 3)))) < 4
    assert [p.name for p in path.parent.iterdir()] == [name]


def test_frames_may_come_one_at_a_time(tmp_path: Path) -> None:
    path = ml.write_video(iter(list(ramp(5))), tmp_path / "a.mp4", fps=5)
    assert iio.imread(path, plugin="FFMPEG").shape == (5, 48, 64, 3)


def test_an_interrupted_write_leaves_the_old_file_and_no_temporary(tmp_path: Path) -> None:
    path = tmp_path / "a.mp4"
    path.write_bytes(b"previous video")

    def failing() -> Iterator[np.ndarray]:
        yield from ramp(3)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        ml.write_video(failing(), path)
    assert path.read_bytes() == b"previous video"
    assert [p.name for p in tmp_path.iterdir()] == ["a.mp4"]


def test_a_stream_is_closed_when_writing_fails(tmp_path: Path) -> None:
    closed = []

    class Stream:
        def __iter__(self) -> Stream:
            return self

        def __next__(self) -> np.ndarray:
            return np.zeros((4, 4), dtype=np.uint8)  # not RGB

        def close(self) -> None:
            closed.append(True)

    with pytest.raises(RenderError, match="uint8 RGB"):
        ml.write_video(Stream(), tmp_path / "a.mp4")
    assert closed == [True] and not list(tmp_path.iterdir())


@pytest.mark.parametrize(("frames", "name", "message"), [
    (ramp(2), "a.avi", r"unknown video format '\.avi'; expected \.mp4 or \.gif"),
    (ramp(0), "a.mp4", "no frames"),
    (ramp(2, 47, 64), "a.mp4", "H.264 needs an even width and height, got 64x47"),
    (ramp(2).astype(float), "a.mp4", "uint8 RGB"),
    ([ramp(1)[0], ramp(1, 50)[0]], "a.gif", "frames change size"),
])
def test_bad_frames_or_names_raise_render_error(tmp_path: Path, frames: np.ndarray, name: str,
                                                message: str) -> None:
    with pytest.raises(RenderError, match=message):
        ml.write_video(frames, tmp_path / name)
    assert not list(tmp_path.iterdir())


def test_odd_sizes_are_fine_for_gif(tmp_path: Path) -> None:
    path = ml.write_video(ramp(3, 47, 63), tmp_path / "a.gif", fps=3)
    assert iio.imread(path).shape == (3, 47, 63, 3)
