"""Videos of runs: one run, and two variants side by side, rendered offscreen.

Simulates the erector under a valve-current sine on q1 with two payloads and writes a video of
the first run and a grid of both (MP4, H.264; no display or GPU needed: MUJOCO_GL=egl).

    python examples/make_video.py -o out/videos [--width 1280 --height 720 --fps 30]
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, default=Path("out/videos"))
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--height", type=int, default=720)
    parser.add_argument("--fps", type=float, default=30.0)
    parser.add_argument("--duration", type=float, default=4.0, help="simulated s")
    args = parser.parse_args(argv)
    os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo's renderer is first used
    import maniplab as ml

    runs = [ml.simulate("erector", inputs={"q1": ml.signals.sine(0.5, frequency=0.25)},
                        duration=args.duration, initial={"dP": "gravity"},
                        overrides={"end_effector.mass": mass}, label=f"payload {mass:g} kg")
            for mass in (3000.0, 5000.0)]
    size = {"width": args.width, "height": args.height, "fps": args.fps}
    single = ml.write_video(ml.viz.iter_frames(runs[0], **size), args.output / "erector.mp4",
                            fps=args.fps)
    grid = ml.write_video(ml.viz.iter_grid(runs, **size), args.output / "payloads.mp4",
                          fps=args.fps)
    print(f"wrote {single} and {grid}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
