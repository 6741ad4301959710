"""The GUI's long work (simulations, model exports), one job at a time, in a background thread.

A job reports its progress through :func:`maniplab.progress.listening` (every progress bar the
library makes in the job's thread) and stops at the library's next cancellation check when
:meth:`Jobs.stop` is called (:class:`maniplab.workers.Cancel`): a stopped simulation raises
before its run is stored, so nothing is half written. A job outlives the page that started it:
closing the browser loses nothing.
"""

from __future__ import annotations

import threading
import traceback
from collections.abc import Callable
from typing import Any

from maniplab.errors import ManiplabError
from maniplab.progress import listening
from maniplab.workers import Cancel

Report = Callable[[str, float | None], None]
"""``report(status line, progress 0..1 or None)``: what the page shows of the job."""

Say = Callable[[str], None]
"""``say(line)``: shows a job's outcome (or its refusal) next to the control that started it."""


class Jobs:
    """Runs one job at a time.

    Args:
        report: called with a status line and the progress (None: no bar) as the job goes.
        on_busy: called with True when a job starts and False when it ends (the page's Run
            buttons disabled and Stop enabled while a job runs).
    """

    def __init__(self, report: Report, on_busy: Callable[[bool], None] | None = None) -> None:
        self.report = report
        self.on_busy = on_busy or (lambda busy: None)
        self._cancel: Cancel | None = None
        self._lock = threading.Lock()

    @property
    def busy(self) -> bool:
        """Whether a job is running."""
        return self._cancel is not None

    def start(self, what: str, work: Callable[[], Any], done: Callable[[Any], str],
              say: Say | None = None) -> bool:
        """Start ``work()`` in a background thread; ``done(result)`` stores its result and returns
        the status line to show (also through ``say``: next to the control that started the
        job). Refused (False, and said) while another job runs."""
        with self._lock:
            if self._cancel is not None:
                (say or (lambda text: self.report(text, None)))(
                    "busy: another job runs; wait for it or stop it first")
                return False
            self._cancel = cancel = Cancel()
        self.on_busy(True)
        self.report(f"{what} ...", 0.0)
        if say is not None:
            say(f"{what} ...")
        threading.Thread(target=self._run, args=(cancel, what, work, done, say), daemon=True,
                         name=f"maniplab-gui: {what}").start()
        return True

    def stop(self) -> None:
        """Stop the running job at its next check (nothing of it is stored)."""
        if self._cancel is not None:
            self._cancel.set()

    def _run(self, cancel: Cancel, what: str, work: Callable[[], Any],
             done: Callable[[Any], str], say: Say | None) -> None:
        try:
            with listening(lambda label, fraction: self.report(f"{label} ...", fraction)):
                result = cancel.run(work)
            if cancel.is_set:
                raise KeyboardInterrupt
            outcome = done(result)
        except KeyboardInterrupt:
            outcome = f"{what}: stopped, nothing stored"
        except ManiplabError as exc:
            outcome = f"{what} failed: {exc}"
        except Exception as exc:  # noqa: BLE001 - a bug: said on the page and logged in full
            traceback.print_exc()
            outcome = (f"{what} failed (a maniplab bug, traceback on the server's stderr): "
                       f"{type(exc).__name__}: {exc}")
        try:  # said before the job ends: whoever waits for the end reads it
            self.report(outcome, None)
            if say is not None:
                say(outcome)
        finally:
            with self._lock:
                self._cancel = None
            self.on_busy(False)
