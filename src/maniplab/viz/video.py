"""Writing frames to a video file, MP4 (H.264) or GIF, with the ffmpeg of the imageio-ffmpeg wheel.

No system ffmpeg is needed. The file is written under a temporary name in the target folder and
renamed when complete, so an interrupted render leaves no half video; Ctrl-C stops ffmpeg at once.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import subprocess
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from maniplab.atomic import atomic_path
from maniplab.viz.gl import RenderError

FORMATS = {".mp4": "h264", ".gif": "gif"}
"""Video suffixes and the ffmpeg codec each is written with."""

CRF = 20
"""H.264 constant rate factor (ffmpeg's default is 23; lower is better)."""

PRESET = "veryfast"
"""x264 preset: twice the speed of the default ("medium") at the same size for these flat-shaded
scenes (about 0.4 MB per 10 s of 1280x720), so encoding keeps up with rendering."""


def write_video(frames: np.ndarray | Iterable[np.ndarray], path: str | os.PathLike[str], *,
                fps: float = 30.0) -> Path:
    """Write ``frames`` to ``path`` (.mp4: H.264, for sharing; .gif: for quick looks).

    Args:
        frames: uint8 RGB frames, an array of shape (F, H, W, 3) or an iterable of (H, W, 3) arrays
            (e.g. :func:`~maniplab.viz.render.iter_frames`, so a long video never sits in memory;
            it is consumed and closed).
        path: the file to write; its folder is created.
        fps: frames per second.

    Returns:
        ``path`` as a Path.

    Raises:
        RenderError: an unknown suffix, no frames, frames of a bad shape or type, an odd size for
            H.264, or ffmpeg failed.
    """
    path = Path(path)
    codec = check_format(path)
    if not fps > 0:
        raise RenderError(f"fps must be a positive number, got {fps}")
    iterator = iter(frames)
    try:
        _write(iterator, path, codec, fps)
    finally:
        close = getattr(iterator, "close", None)
        if close is not None:  # a frame stream frees its OpenGL context now, even on error
            close()
    return path


def _write(frames: Iterator[np.ndarray], path: Path, codec: str, fps: float) -> None:
    import imageio_ffmpeg

    first = next(frames, None)
    if first is None:
        raise RenderError(f"cannot write '{path.name}': no frames")
    shape = _check_frame(first, None)
    check_format(path, shape[1], shape[0])
    with atomic_path(path) as tmp:
        argv = [imageio_ffmpeg.get_ffmpeg_exe(), *_ffmpeg_args(tmp, shape, codec, fps)]
        _encode(itertools.chain([first], frames), shape, argv, path)


def _ffmpeg_args(tmp: Path, shape: tuple[int, int], codec: str, fps: float) -> list[str]:
    """ffmpeg's arguments: raw RGB frames of ``shape`` (height, width) on stdin -> ``tmp``."""
    height, width = shape
    args = ["-v", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{width}x{height}",
            "-r", f"{fps}", "-i", "-", "-an", "-vcodec", codec]
    if codec == "h264":
        args += ["-pix_fmt", "yuv420p", "-crf", f"{CRF}", "-preset", PRESET]
    else:  # one palette for the whole GIF, computed from all its frames
        args += ["-vf", "split[s0][s1];[s0]palettegen[p];[s1][p]paletteuse", "-f", "gif"]
    return [*args, "-y", str(tmp)]


def _encode(frames: Iterator[np.ndarray], shape: tuple[int, int], argv: list[str],
            path: Path) -> None:
    """Pipe ``frames`` into the ffmpeg command ``argv`` and wait for it to finish the file.

    ffmpeg runs in a session of its own, so Ctrl-C at the terminal reaches maniplab only: an
    interrupted (or failed) write kills and reaps ffmpeg, and the KeyboardInterrupt (or error)
    is what the caller sees, never a broken pipe.
    """
    # its messages go to a file: a pipe nobody reads while frames are written could fill up
    with tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stderr=log, start_new_session=True)
        stdin = proc.stdin
        assert stdin is not None, "a pipe"
        try:
            try:
                for frame in frames:
                    _check_frame(frame, shape)
                    stdin.write(np.ascontiguousarray(frame).tobytes())
                stdin.close()
            except BrokenPipeError:
                pass  # ffmpeg quit early; its status and message say why
            if proc.wait():
                log.seek(0)
                message = " ".join(log.read().decode(errors="replace").split())
                raise RenderError(f"ffmpeg could not write '{path.name}': {message}")
        finally:
            _reap(proc)


def _reap(proc: subprocess.Popen[bytes]) -> None:
    """Kill ffmpeg unless it has finished, wait for it, close its pipes."""
    if proc.poll() is None:
        proc.kill()
        proc.wait()
    if proc.stdin is not None:
        with contextlib.suppress(OSError):  # unwritten frames meet a closed pipe: dropped
            proc.stdin.close()


def check_format(path: Path, width: int | None = None, height: int | None = None) -> str:
    """The codec for ``path``'s suffix; checks that ``width`` x ``height`` suits it, if given.

    Raises:
        RenderError: an unknown suffix, or an odd size for H.264 (4:2:0 colour needs even sizes).
    """
    codec = FORMATS.get(path.suffix.lower())
    if codec is None:
        raise RenderError(f"cannot write '{path.name}': unknown video format '{path.suffix}'; "
                          f"expected {' or '.join(FORMATS)}")
    if codec == "h264" and width is not None and height is not None and (width % 2 or height % 2):
        raise RenderError(f"cannot write '{path.name}': H.264 needs an even width and height, got "
                          f"{width}x{height}; render an even size or write a .gif")
    return codec


def _check_frame(frame: np.ndarray, shape: tuple[int, int] | None) -> tuple[int, int]:
    frame = np.asarray(frame)
    if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
        raise RenderError(f"a frame must be uint8 RGB of shape (H, W, 3), got {frame.dtype} "
                          f"{frame.shape}")
    if shape is not None and frame.shape[:2] != shape:
        raise RenderError(f"frames change size: {frame.shape[1]}x{frame.shape[0]} after "
                          f"{shape[1]}x{shape[0]}")
    return frame.shape[:2]
