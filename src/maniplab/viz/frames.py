"""Running a composition of frames: all into one array, or one at a time (for streaming to ffmpeg).

A composition is anything that draws frame k into an image (a single run, a grid, an overlay). It
owns OpenGL contexts, so it is closed when the frames are done, also on error or when a consumer
stops early.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Protocol

import numpy as np

from maniplab.progress import Progress


class Composition(Protocol):
    """Draws the frames of one video."""

    width: int
    height: int
    times: np.ndarray  # frame times, s, shape (F,)

    def compose(self, k: int, out: np.ndarray) -> None:
        """Draw frame ``k`` (in order) into ``out``, uint8, shape (height, width, 3)."""

    def close(self) -> None:
        """Free OpenGL contexts."""


def collect(composition: Composition, label: str, progress: bool | None) -> np.ndarray:
    """Every frame, uint8, shape (F, height, width, 3); closes ``composition``."""
    try:
        frames = np.empty((len(composition.times), composition.height, composition.width, 3),
                          dtype=np.uint8)
        bar = Progress(len(frames), label, enabled=progress)
        for k in range(len(frames)):
            composition.compose(k, frames[k])
            bar.step(f"t = {composition.times[k]:.2f} s")
        bar.close()
        return frames
    finally:
        composition.close()


class FrameStream:
    """The frames of a composition one by one (each a new array, shape (height, width, 3)).

    ``len()`` is the number of frames. The composition is closed when the stream is exhausted or
    closed (:meth:`close`, also called by :func:`~maniplab.viz.video.write_video`).
    """

    def __init__(self, composition: Composition, label: str, progress: bool | None) -> None:
        self._composition: Composition | None = composition
        self._count = len(composition.times)
        self._next = 0
        self._bar = Progress(self._count, label, enabled=progress)

    def __len__(self) -> int:
        return self._count

    def __iter__(self) -> Iterator[np.ndarray]:
        return self

    def __next__(self) -> np.ndarray:
        composition = self._composition
        if composition is None or self._next >= self._count:
            self.close()
            raise StopIteration
        out = np.empty((composition.height, composition.width, 3), dtype=np.uint8)
        try:
            composition.compose(self._next, out)
        except BaseException:
            self.close()
            raise
        self._bar.step(f"t = {composition.times[self._next]:.2f} s")
        self._next += 1
        return out

    def close(self) -> None:
        """Free the composition's OpenGL contexts (idempotent)."""
        if self._composition is not None:
            self._composition.close()
            self._composition = None
            if self._next:
                self._bar.close()
