"""A one-line progress bar on stderr for symbolic generation, shown only on a terminal."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class Progress:
    """Counts steps of a long job and redraws one line on a terminal; silent otherwise.

    Args:
        total: number of steps.
        label: what is being done, e.g. "generating erector model".
        enabled: force on or off; None means "when stderr is a terminal".
    """

    def __init__(self, total: int, label: str, enabled: bool | None = None,
                 stream: TextIO | None = None) -> None:
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.total, self.label, self.done = max(total, 1), label, 0
        self.start = time.perf_counter()

    def step(self, what: str) -> None:
        """One step done; ``what`` is shown next to the bar."""
        self.done += 1
        if not self.enabled:
            return
        width = 24
        filled = width * self.done // self.total
        elapsed = time.perf_counter() - self.start
        self.stream.write(f"\r{self.label} [{'#' * filled}{'.' * (width - filled)}] "
                          f"{self.done}/{self.total} {what:<28.28} {elapsed:5.1f} s")
        self.stream.flush()

    def close(self) -> None:
        """End the line (on a terminal)."""
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()
