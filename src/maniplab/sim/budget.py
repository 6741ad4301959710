"""What a run will store, and whether it fits: refused before its first step when it does not.

A run records ``rows`` samples of ``bytes_per_sample`` bytes each (the time and every signal,
exactly what the recorder allocates). In memory that must fit in :data:`MEMORY_SHARE` of the
memory available (``/proc/meminfo``'s MemAvailable, a cgroup's limit when lower); streamed to a
file (``stream=``), in :data:`DISK_SHARE` of the free space of the file's folder. A run that does
not fit is refused with one line giving the figure, what is available and the options that work.
"""

from __future__ import annotations

import contextlib
import math
import os
import shutil
from pathlib import Path

from maniplab.sim.errors import InputError

MEMORY_SHARE = 0.8
"""The share of the available memory a run's recording may take (the rest: the process, the
run's later use, the other programs)."""

DISK_SHARE = 0.9
"""The share of a folder's free space a streamed run file may take."""

_CGROUP_FILES = (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                 ("/sys/fs/cgroup/memory/memory.limit_in_bytes",
                  "/sys/fs/cgroup/memory/memory.usage_in_bytes"))
"""(limit, usage) files of the process's memory cgroup, v2 then v1, as a container sees them."""


MIN_DT = 1e-9
"""The shortest step a plant takes, s (a nanosecond: far below any arm's need, well above the
steps whose counts overflow; a shorter one is refused in one line)."""

MAX_STEPS = 2**53
"""The most steps one run may take: every step's time t0 + k dt is then distinct and exact in
k, and the count fits the C loop's 64-bit counters."""


def check_step(dt: float, field: str = "dt") -> float:
    """``dt`` as a float, when it is a step a plant can take.

    Raises:
        InputError: not a finite number of at least :data:`MIN_DT` seconds, naming ``field``.
    """
    try:
        value = float(dt)
    except (TypeError, ValueError):
        raise InputError(f"{field} must be a number of seconds, got {dt!r}") from None
    if not (math.isfinite(value) and value > 0.0):
        raise InputError(f"{field} must be a positive number of seconds, got {dt!r}")
    if value < MIN_DT:
        raise InputError(f"{field} = {value:g} s is shorter than the shortest step a plant "
                         f"takes, {MIN_DT:g} s")
    return value


def steps_of(duration: float, dt: float) -> int:
    """The whole steps of ``dt`` in ``duration`` (at least one).

    Raises:
        InputError: ``duration`` not a positive finite number of seconds, or a run of more than
            :data:`MAX_STEPS` steps (naming the longest duration at this step).
    """
    if isinstance(duration, bool) or not (isinstance(duration, (int, float)) and
                                          math.isfinite(duration) and duration > 0.0):
        raise InputError(f"duration must be a positive number of seconds, got {duration!r}")
    ratio = duration / dt
    if not ratio < MAX_STEPS:
        raise InputError(f"duration = {duration:g} s is more steps of {dt:g} s than one run "
                         f"takes ({MAX_STEPS:.3g}): at most {MAX_STEPS * dt:.3g} s at this step")
    return max(1, round(ratio))


def rows_of(steps: int, every: int) -> int:
    """The samples a run of ``steps`` steps records, one every ``every`` steps and the last."""
    return steps // every + 1 + (1 if steps % every else 0)


def available_memory() -> int:
    """The memory this process can still take, bytes: MemAvailable of ``/proc/meminfo`` (else
    the free pages from ``os.sysconf``), or less when a cgroup limits the process."""
    free = _meminfo_available()
    if free is None:
        free = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    return min(free, _cgroup_room())


def free_disk(path: str | os.PathLike[str]) -> int:
    """The free space of the file system that a file at ``path`` would go to, bytes (its nearest
    existing folder's)."""
    folder = Path(path).absolute().parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    return shutil.disk_usage(folder).free


def check_memory(stored: int, *, duration: float, dt: float, every: int,
                 bytes_per_sample: int, overhead: int) -> None:
    """Refuse a run whose recording would not fit in memory.

    Args:
        stored: the bytes the run would store (samples × bytes_per_sample).
        duration: simulated time, s.
        dt: the step, s.
        every: steps per sample.
        bytes_per_sample: bytes of one sample (time and every signal).
        overhead: the recorder's fixed bytes besides the stored arrays (its chunk buffers).

    Raises:
        InputError: one line: the figure, the memory available, and the options.
    """
    room = available_memory()
    budget = MEMORY_SHARE * room - overhead
    if stored <= budget:
        return
    suggest = suggest_sample_dt(duration, dt, bytes_per_sample, budget)
    options = ([f"record less with --sample-dt {suggest:g} (sample_dt={suggest:g})"] if suggest
               else [])
    options.append("stream to disk with --stream (stream=FILE)")
    raise InputError(f"run would store {format_bytes(stored)} ({_what(duration, dt, every)}, "
                     f"{format_bytes(bytes_per_sample)} per sample) but {format_bytes(room)} is "
                     f"available: {' or '.join(options)}")


def check_disk(stored: int, path: str | os.PathLike[str], *, duration: float, dt: float,
               every: int, bytes_per_sample: int) -> None:
    """Refuse a streamed run whose file would not fit in its folder's free space.

    Args:
        stored: the bytes of the run's arrays (the file is a little larger: its header).
        path: the run file to write.
        duration: simulated time, s.
        dt: the step, s.
        every: steps per sample.
        bytes_per_sample: bytes of one sample (time and every signal).

    Raises:
        InputError: one line: the figure, the free space, and the option.
    """
    room = free_disk(path)
    budget = DISK_SHARE * room
    if stored <= budget:
        return
    suggest = suggest_sample_dt(duration, dt, bytes_per_sample, budget)
    option = (f": record less with --sample-dt {suggest:g} (sample_dt={suggest:g})" if suggest
              else "")
    raise InputError(f"{path}: run would write {format_bytes(stored)} "
                     f"({_what(duration, dt, every)}, {format_bytes(bytes_per_sample)} per "
                     f"sample) but {format_bytes(room)} is free there{option}")


def suggest_sample_dt(duration: float, dt: float, bytes_per_sample: int,
                      budget: float) -> float | None:
    """The smallest recording interval of the form 1, 2 or 5 × 10^k s whose samples fit in
    ``budget`` bytes, or None when none does (not even two samples).

    Args:
        duration: simulated time, s.
        dt: the step, s.
        bytes_per_sample: bytes of one sample.
        budget: the bytes the samples may take.
    """
    steps = steps_of(duration, dt)
    if rows_of(steps, steps) * bytes_per_sample > budget:
        return None
    exponent = math.floor(math.log10(dt))
    for k in range(exponent, exponent + 40):
        for mantissa in (1, 2, 5):
            value = mantissa * 10.0 ** k
            every = max(1, round(value / dt))
            if value >= dt and rows_of(steps, min(every, steps)) * bytes_per_sample <= budget:
                return float(f"{value:.12g}")
    return None


def format_bytes(size: float) -> str:
    """``size`` bytes in words: "470 B", "4.1 KB", "282 MB", "412 GB" (powers of 1000)."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("KB", 1e3)):
        if size >= scale:
            return f"{size / scale:.2g} {unit}" if size < 10 * scale else \
                f"{size / scale:.0f} {unit}"
    return f"{size:.0f} B"


def _what(duration: float, dt: float, every: int) -> str:
    """"1.0e9 s at 1 kHz": the duration and the sampling rate."""
    rate = 1.0 / (every * dt)
    hz = next((f"{rate / s:g} {u}" for u, s in (("MHz", 1e6), ("kHz", 1e3)) if rate >= s),
              f"{rate:.3g} Hz")
    span = f"{duration:.1e}".replace("e+0", "e").replace("e+", "e") if duration >= 1e5 \
        else f"{duration:g}"
    return f"{span} s at {hz}"


def _meminfo_available() -> int | None:
    """MemAvailable of /proc/meminfo, bytes, or None where there is none."""
    with contextlib.suppress(OSError, ValueError), open("/proc/meminfo", encoding="ascii") as file:
        for line in file:
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    return None


def _cgroup_room() -> int:
    """What the process's memory cgroup still allows, bytes (a huge number without a limit)."""
    room = 1 << 62
    for limit_file, usage_file in _CGROUP_FILES:
        with contextlib.suppress(OSError, ValueError):
            limit = Path(limit_file).read_text().strip()
            if limit != "max" and int(limit) < room:
                room = min(room, int(limit) - int(Path(usage_file).read_text()))
    return max(room, 0)
