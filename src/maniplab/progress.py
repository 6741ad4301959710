"""Progress bars for long work (symbolic generation, simulation, sweeps, rendering).

A thin layer over tqdm: drawn on stderr when it is a terminal (or when asked), silent otherwise.
"""

from __future__ import annotations

import sys
from typing import TextIO

from tqdm import tqdm


class Progress:
    """A bar of ``total`` steps.

    Args:
        total: number of steps.
        label: what is being done, e.g. "generating the erector model".
        enabled: force on or off; None means "when the stream is a terminal".
        stream: where to draw (default stderr).
    """

    def __init__(self, total: int, label: str, enabled: bool | None = None,
                 stream: TextIO | None = None) -> None:
        stream = stream or sys.stderr
        self.enabled = stream.isatty() if enabled is None else bool(enabled)
        self._bar = tqdm(total=max(total, 1), desc=label, file=stream, disable=not self.enabled,
                         dynamic_ncols=True, leave=True)

    def step(self, what: str = "") -> None:
        """One step done; ``what`` is shown after the bar."""
        if self.enabled:
            self._bar.set_postfix_str(what, refresh=False)
        self._bar.update()

    def close(self) -> None:
        """Finish the bar (on a terminal: end its line)."""
        self._bar.close()
