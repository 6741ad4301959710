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


class Jobs:
    """Runs one job at a time.

    Args:
        report: called with a status line and the progress (None: no bar) as the job goes.
    """

    def __init__(self, report: Report) -> None:
        self.report = report
        self._cancel: Cancel | None = None
        self._lock = threading.Lock()

    @property
    def busy(self) -> bool:
        """Whether a job is running."""
        return self._cancel is not None

    def start(self, what: str, work: Callable[[], Any], done: Callable[[Any], str]) -> bool:
        """Start ``work()`` in a background thread; ``done(result)`` stores its result and returns
        the status line to show. Refused (False, and said) while another job runs."""
        with self._lock:
            if self._cancel is not None:
                self.report("busy: stop the running job first", None)
                return False
            self._cancel = cancel = Cancel()
        self.report(f"{what} ...", 0.0)
        threading.Thread(target=self._run, args=(cancel, what, work, done), daemon=True,
                         name=f"maniplab-gui: {what}").start()
        return True

    def stop(self) -> None:
        """Stop the running job at its next check (nothing of it is stored)."""
        if self._cancel is not None:
            self._cancel.set()

    def _run(self, cancel: Cancel, what: str, work: Callable[[], Any],
             done: Callable[[Any], str]) -> None:
        try:
            with listening(lambda label, fraction: self.report(f"{label} ...", fraction)):
                result = cancel.run(work)
            if cancel.is_set:
                raise KeyboardInterrupt
            self.report(done(result), None)
        except KeyboardInterrupt:
            self.report(f"{what}: stopped, nothing stored", None)
        except ManiplabError as exc:
            self.report(f"{what} failed: {exc}", None)
        except Exception as exc:  # noqa: BLE001 - a bug: said on the page and logged in full
            traceback.print_exc()
            self.report(f"{what} failed (a maniplab bug, traceback on the server's stderr): "
                        f"{type(exc).__name__}: {exc}", None)
        finally:
            with self._lock:
                self._cancel = None
