"""Speed of offscreen rendering: frames per second at 1280x720, rendering alone and with encoding.

The reference job is the issue's target: a 10 s, 30 fps, 1280x720 video of the erector (301
frames), rendered and encoded to H.264 in one stream (ffmpeg encodes while the next frames are
drawn), with the default look (antialiased, no shadows), with shadows, and without antialiasing.
Also measured: rendering alone, encoding alone, a 4-run grid and a 3-run overlay. The run is scripted
(both big joints swinging, the elbow sticking for a while): rendering never simulates, so any run
of the same length costs the same. Medians over ``--repeats`` runs. Not part of the test suite.

    python benchmarks/bench_render.py             # ~6 minutes on 2 cores (software OpenGL)
    python benchmarks/bench_render.py --repeats 1
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

SPEC = "erector"
WIDTH, HEIGHT, FPS, DURATION = 1280, 720, 30.0, 10.0


def erector_run(scale: float = 1.0, payload: float | None = None):  # -> Run
    """10 s of the erector swinging q1 and q2, the elbow (q2) sticking from 4 to 5 s."""
    import maniplab as ml
    from maniplab.friction.modes import FrictionMode
    from maniplab.sim.run import Run

    spec = ml.builtin_spec(SPEC)
    if payload is not None:
        spec = spec.with_overrides({"end_effector.mass": payload})
    t = np.linspace(0.0, DURATION, 1001)
    q = np.zeros((len(t), spec.n))
    q[:, 0] = scale * 0.6 * np.sin(0.6 * t)
    q[:, 1] = scale * 0.8 * np.sin(0.9 * t)
    q[:, 5] = 0.2 * np.sin(1.3 * t)
    mode = np.zeros(q.shape, dtype=int)
    mode[(t >= 4.0) & (t < 5.0), 1] = FrictionMode.STICK
    return Run(t=t, signals={"q": q, "mode": mode}, spec=spec)


def cpu_seconds() -> float:
    """CPU time of this process (all threads: llvmpipe rasterises on several) and of its finished
    children (ffmpeg), s."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(
        resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def median_time(job: Callable[[], object], repeats: int) -> tuple[float, float]:
    """Median wall time and median CPU time of ``job()``, s.

    On a shared machine the wall time grows with the load; the CPU time much less.
    """
    walls, cpus = [], []
    for _ in range(repeats):
        start, cpu = time.perf_counter(), cpu_seconds()
        job()
        walls.append(time.perf_counter() - start)
        cpus.append(cpu_seconds() - cpu)
    return statistics.median(walls), statistics.median(cpus)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="runs per figure (default: 3)")
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")  # a script's choice, as in the CLI's main()

    import maniplab as ml
    from maniplab import viz

    run = erector_run()
    count = int(DURATION * FPS) + 1
    size = {"width": WIDTH, "height": HEIGHT, "fps": FPS}
    rows: list[tuple[str, ...]] = []
    load = os.getloadavg()[0]

    def row(what: str, wall: float, cpu: float, note: str) -> None:
        rows.append((what, f"{wall:.1f} s", f"{count / wall:.1f}", f"{cpu:.1f} s", note))

    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "erector.mp4"
        for label, look in (("default: antialiased, no shadows", {}),
                            ("shadows on", {"shadows": True}),
                            ("antialiasing off", {"antialias": False})):
            wall, cpu = median_time(lambda look=look: ml.write_video(
                viz.iter_frames(run, **size, **look), out, fps=FPS), args.repeats)
            note = f"{out.stat().st_size / 1e6:.1f} MB" + ("; target < 20 s" if not look else "")
            row(f"10 s video, render + encode, {label}", wall, cpu, note)
            wall, cpu = median_time(lambda look=look: viz.render(run, **size, **look), args.repeats)
            row(f"  rendering alone, {label}", wall, cpu, "frames kept in memory")
        frames = viz.render(run, **size)
        wall, cpu = median_time(lambda: ml.write_video(frames, out, fps=FPS), args.repeats)
        row("  H.264 encoding alone (imageio-ffmpeg's ffmpeg)", wall, cpu,
            f"x264 preset {viz.video.PRESET}, CRF {viz.video.CRF}")
        variants = [erector_run(s, p) for s, p in ((1.0, 4000.0), (0.8, 5000.0), (0.6, 6000.0),
                                                   (0.4, 3000.0))]
        wall, cpu = median_time(lambda: ml.write_video(viz.iter_grid(variants, **size), out,
                                                       fps=FPS), args.repeats)
        grid = viz.grid_layout(len(variants), WIDTH, HEIGHT)
        row("grid of 4 runs, render + encode", wall, cpu,
            f"{grid.cols}x{grid.rows} tiles of {grid.tile_width}x{grid.tile_height}")
        wall, cpu = median_time(lambda: ml.write_video(viz.iter_overlay(variants[:3], **size), out,
                                                       fps=FPS), args.repeats)
        row("overlay of 3 runs, render + encode", wall, cpu, "one scene, two ghosts")
    load = max(load, os.getloadavg()[0])

    print(f"{SPEC}, {WIDTH}x{HEIGHT}, {FPS:g} fps, {count} frames per video, "
          f"MUJOCO_GL={os.environ['MUJOCO_GL']}, {os.cpu_count()} CPUs, medians of "
          f"{args.repeats}; load average (1 min) up to {load:.1f} while measuring\n")
    print("| what | wall time | frames/s | CPU time | note |\n|---|---|---|---|---|")
    for row in rows:
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
