"""Progress of long work (model generation, simulation, cross-validation, sweeps, rendering).

On a terminal: a tqdm bar on stderr. Elsewhere (a log file, a pipe, CI): one plain line per stage
that lasts, so a log shows what a long job is doing without filling up with bars; a short job
prints nothing at all. A stage that is still running after :data:`LINE_AFTER` seconds is
announced ("...: compiling 9 C files, 2 at a time ..."), and its end is written with its time; a
stream of short steps writes a status line every :data:`STATUS_EVERY` seconds.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from collections.abc import Callable, Iterator
from typing import TextIO

from tqdm import tqdm

LINE_AFTER = 1.0
"""A stage running longer than this (s) gets lines in a log."""

STATUS_EVERY = 10.0
"""Interval (s) of the status lines of a run of short steps in a log."""


Listener = Callable[[str, float], None]
"""``listener(label, fraction)``: a bar named ``label`` is ``fraction`` (0..1) done."""

_local = threading.local()


@contextlib.contextmanager
def listening(listener: Listener) -> Iterator[None]:
    """Send the progress of every bar made in this thread, inside the block, to ``listener`` as
    well (the GUI's progress bar listens to the simulations it starts)."""
    outer = getattr(_local, "listener", None)
    _local.listener = listener
    try:
        yield
    finally:
        _local.listener = outer


class Progress:
    """A bar of ``total`` steps.

    Args:
        total: number of steps.
        label: what is being done, e.g. "generating the erector model".
        enabled: force the bar on or off; None means a bar on a terminal and lines elsewhere.
        stream: where to draw (default stderr).
    """

    def __init__(self, total: int, label: str, enabled: bool | None = None,
                 stream: TextIO | None = None) -> None:
        stream = stream or sys.stderr
        tty = stream.isatty()
        self.enabled = tty if enabled is None else bool(enabled)
        self._lines = _Lines(label, max(total, 1), stream) if enabled is None and not tty else None
        self._bar = tqdm(total=max(total, 1), desc=label, file=stream, disable=not self.enabled,
                         dynamic_ncols=True, leave=True)
        self._label, self._total, self._done = label, max(total, 1), 0
        self._listener: Listener | None = getattr(_local, "listener", None)

    def start(self, what: str) -> None:
        """A stage begins (shown after the bar; in a log, announced if it lasts)."""
        if self.enabled:
            self._bar.set_postfix_str(what)
        if self._lines:
            self._lines.start(what)

    def step(self, what: str = "") -> None:
        """One step done; ``what`` is shown after the bar."""
        if self.enabled:
            self._bar.set_postfix_str(what, refresh=False)
        if self._lines:
            self._lines.step(what)
        self._bar.update()
        self._done += 1
        if self._listener is not None:
            self._listener(self._label, min(self._done / self._total, 1.0))

    def close(self) -> None:
        """Finish the bar (on a terminal: end its line)."""
        if self._lines:
            self._lines.close()
        self._bar.close()


class _Lines:
    """The log form of a progress bar (module docstring)."""

    def __init__(self, label: str, total: int, stream: TextIO) -> None:
        self.label, self.total, self.stream = label, total, stream
        self.done = 0
        self.began = self.stage_began = self.last_line = time.monotonic()
        self.stage = ""
        self.announced = False
        self._timer: threading.Timer | None = None
        self._lock = threading.Lock()

    def start(self, what: str) -> None:
        self._cancel()
        self.stage, self.stage_began, self.announced = what, time.monotonic(), False
        self._timer = threading.Timer(LINE_AFTER, self._announce)
        self._timer.daemon = True
        self._timer.start()

    def _announce(self) -> None:
        with self._lock:
            self.announced = True
            self._write(f"{self.stage} ...")

    def step(self, what: str) -> None:
        self._cancel()
        now = time.monotonic()
        self.done += 1
        with self._lock:
            long_stage = self.announced or now - self.stage_began >= LINE_AFTER
            if long_stage or now - self.last_line >= STATUS_EVERY:
                percent = f"{100 * self.done // self.total}%"
                self._write(f"{what or percent} ({now - self.began:.1f} s)")
        self.stage_began, self.announced = now, False

    def close(self) -> None:
        self._cancel()

    def _cancel(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    def _write(self, text: str) -> None:
        self.last_line = time.monotonic()
        self.stream.write(f"{self.label}: {text}\n")
        self.stream.flush()
