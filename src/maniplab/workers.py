"""Worker pools that answer Ctrl-C: processes that die with their parent, threads told to stop.

A process pool's workers ignore SIGINT (the terminal sends it to the whole process group; the
parent answers it and kills them, see :func:`stop_processes`) and end when their parent dies,
even by ``kill -9``: on Linux through ``prctl(PR_SET_PDEATHSIG)``, elsewhere through a thread that
polls the parent's pid. Work running in threads cannot be interrupted from outside, so it checks
a :class:`Cancel` flag at its pauses (:func:`check_cancelled`).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from typing import Any, TypeVar

T = TypeVar("T")

PR_SET_PDEATHSIG = 1
"""prctl option: the signal a process gets when its parent dies (linux/prctl.h)."""

POLL_S = 0.5
"""How often the fallback watcher checks that the parent lives, s."""


def process_pool(workers: int) -> cf.ProcessPoolExecutor:
    """A pool of ``workers`` processes, children of this one, that ignore SIGINT and die with it."""
    method = multiprocessing.get_start_method()
    # a fork server's workers would be its children, not ours
    context = multiprocessing.get_context("spawn" if method == "forkserver" else method)
    from maniplab.actuators.registry import loaded_plugins

    return cf.ProcessPoolExecutor(max_workers=workers, mp_context=context,
                                  initializer=init_worker,
                                  initargs=(os.getpid(), loaded_plugins()))


def init_worker(parent: int, plugins: tuple[str, ...] = ()) -> None:
    """Initializer of a pool's worker process: ignore SIGINT, die when ``parent`` (pid) dies,
    load the plugin modules the parent had loaded on purpose (a spawned worker starts without
    them; one that cannot be loaded fails the variants that need it, with the registry's
    message)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent(parent)
    from maniplab.actuators.registry import PluginLookupError, load_plugins

    for module in plugins:
        with contextlib.suppress(PluginLookupError):
            load_plugins(module)


def die_with_parent(parent: int) -> None:
    """End this process (SIGKILL) when its parent, the process ``parent`` (pid), ends."""
    if not _set_parent_death_signal():
        threading.Thread(target=_watch, args=(parent,), name="maniplab-parent-watch",
                         daemon=True).start()
    if os.getppid() != parent:  # the parent died before we were watching: we were re-parented
        os.kill(os.getpid(), signal.SIGKILL)


def _set_parent_death_signal() -> bool:
    """Ask Linux to SIGKILL this process when its parent thread ends; False where it cannot."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return bool(libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0)
    except (OSError, AttributeError):
        return False


def _watch(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(POLL_S)
    os.kill(os.getpid(), signal.SIGKILL)


def stop_processes(pool: cf.ProcessPoolExecutor) -> None:
    """Stop a process pool now: drop the calls not started, kill the workers, reap them."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # private, no public way
    for process in processes:
        process.kill()
    for process in processes:
        process.join()
    pool.shutdown(wait=True, cancel_futures=True)


class Cancel:
    """A flag that stops work running in pool threads at its next :func:`check_cancelled`."""

    _current = threading.local()

    def __init__(self) -> None:
        self._event = threading.Event()

    def set(self) -> None:
        """Cancel: every call made through :meth:`run` raises KeyboardInterrupt at its next check."""
        self._event.set()

    def run(self, fn: Callable[..., T], /, *args: Any, **kwargs: Any) -> T:
        """``fn(*args, **kwargs)`` in this thread, under this flag."""
        with self._scope():
            return fn(*args, **kwargs)

    @contextlib.contextmanager
    def _scope(self) -> Iterator[None]:
        outer = getattr(Cancel._current, "flag", None)
        Cancel._current.flag = self
        try:
            yield
        finally:
            Cancel._current.flag = outer

    @property
    def is_set(self) -> bool:
        return self._event.is_set()


class Threads(cf.ThreadPoolExecutor):
    """Threads whose running work stops at its next :func:`check_cancelled` once :meth:`stop` is
    called (the plant's run loop checks at every pause)."""

    def __init__(self, workers: int) -> None:
        super().__init__(max_workers=workers)
        self.cancel = Cancel()

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> cf.Future:
        with interrupts_deferred():
            return super().submit(self.cancel.run, fn, *args, **kwargs)

    def map_results(self, fn: Callable[..., T], items: Iterable[tuple[Any, ...]],
                    each: Callable[[], object] | None = None) -> list[T]:
        """``[fn(*item) for item in items]`` computed in the threads; ``each()`` is called in
        this thread as each result comes in (a progress bar's step)."""
        futures = {self.submit(fn, *item): i for i, item in enumerate(items)}
        results: dict[int, T] = {}
        for future in completed(futures):
            results[futures[future]] = future.result()
            if each is not None:
                each()
        return [results[i] for i in range(len(futures))]

    def stop(self) -> None:
        """Cancel the running work, drop the queued work, and wait for the threads."""
        self.cancel.set()
        self.shutdown(wait=True, cancel_futures=True)


@contextlib.contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Ctrl-C during the block is raised when the block ends, not in its middle.

    A KeyboardInterrupt raised inside ``concurrent.futures`` (between a lock's acquisition and
    the ``with`` that releases it) can leave a lock of the pool or of a future held, and the
    pool's shutdown then waits forever. Only the main thread receives signals, and only Python's
    default handler is replaced; elsewhere the block runs as it is.
    """
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield
        return
    caught: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if caught:
        raise KeyboardInterrupt


def completed(futures: Iterable[cf.Future], poll: float = 0.1) -> Iterator[cf.Future]:
    """The futures as they complete (as ``concurrent.futures.as_completed``), with Ctrl-C taken
    only between waits of ``poll`` seconds (:func:`interrupts_deferred`)."""
    pending = set(futures)
    while pending:
        with interrupts_deferred():
            done, pending = cf.wait(pending, timeout=poll, return_when=cf.FIRST_COMPLETED)
        yield from done


def check_cancelled() -> None:
    """Raise KeyboardInterrupt when the work of the calling thread was cancelled (:class:`Cancel`).

    Long work calls this at its pauses; outside :meth:`Cancel.run` it does nothing.
    """
    flag = getattr(Cancel._current, "flag", None)
    if flag is not None and flag.is_set:
        raise KeyboardInterrupt


def interruptible(fn: Callable[..., T], /, *args: Any) -> T:
    """``fn(*args)`` run in a helper thread while this one waits in short slices, so that Ctrl-C
    is answered at once even when ``fn`` spends seconds in C code (symengine's cse) that checks
    no signals. After Ctrl-C the helper finishes in the background and its result is dropped
    (a daemon thread: it does not keep the process alive)."""
    done = threading.Event()
    outcome: dict[str, Any] = {}

    def target() -> None:
        try:
            outcome["value"] = fn(*args)
        except BaseException as exc:  # noqa: BLE001 - handed to the waiting thread
            outcome["error"] = exc
        finally:
            done.set()

    threading.Thread(target=target, name="maniplab-interruptible", daemon=True).start()
    while not done.wait(0.05):
        pass
    if "error" in outcome:
        raise outcome["error"]
    value: T = outcome["value"]
    return value
