"""The GUI: start-up time and replay frame rate, each as a ratio against a peer in the same run.

Run: .venv/bin/python benchmarks/bench_gui.py [--repeats 5]   (needs chromium and chromedriver)

Printed (medians over the repeats):

* start-up: ``maniplab gui``'s server (``Gui(erector)``: viser server, the four tabs, the 3D
  erector) ready to serve, against a bare ``viser.ViserServer()`` (the peer); and the page in
  headless chromium until the joint table shows, against the bare viser page until its canvas
  shows.
* replay, server side: frames per second at which the Watch tab poses the erector (one run, and
  three runs as ghosts), against MuJoCo's offscreen renderer drawing the same run's frames
  (``ml.render``, 640x360, the videos' path; the peer).
* replay, browser side: frames per second the exported HTML replay draws while it plays in
  headless chromium on the software (SwiftShader) WebGL of a machine without GPU, against the
  same browser's frame rate on an empty viser scene.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import socket
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import browser as web
import viser

import maniplab as ml
from maniplab.gui.app import Gui
from maniplab.gui.replay import Replay, recording_server, replay_html

FRAME_RATE_JS = """
const done = arguments[arguments.length - 1];
let frames = 0; const t0 = performance.now();
function tick() { frames++; if (performance.now() - t0 < 3000) requestAnimationFrame(tick);
                  else done(frames * 1000 / (performance.now() - t0)); }
requestAnimationFrame(tick);
"""


def _port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _median_time(call, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        began = time.perf_counter()
        call()
        times.append(time.perf_counter() - began)
    return statistics.median(times)


def startup(repeats: int) -> None:
    folder = tempfile.mkdtemp()
    spec = ml.builtin_spec("erector")

    def ours() -> None:
        Gui(spec, folder, port=_port()).close()

    def peer() -> None:
        with contextlib.redirect_stdout(io.StringIO()):
            viser.ViserServer(host="127.0.0.1", port=_port(), verbose=False).stop()

    a, b = _median_time(ours, repeats), _median_time(peer, repeats)
    print(f"server start-up: maniplab gui {a:.2f} s, bare viser {b:.2f} s: ratio {a / b:.1f}")
    page_times, bare_times = [], []
    with web.chromium() as driver:
        for _ in range(repeats):
            app = Gui(spec, folder, port=_port())
            began = time.perf_counter()
            driver.get(app.url)
            web.wait(lambda: web.visible(driver, "//table[@id='ml-joints']"), "the table")
            page_times.append(time.perf_counter() - began)
            app.close()
            with contextlib.redirect_stdout(io.StringIO()):
                bare = viser.ViserServer(host="127.0.0.1", port=_port(), verbose=False)
            began = time.perf_counter()
            driver.get(f"http://127.0.0.1:{bare.get_port()}")
            web.wait(lambda: driver.find_elements("css selector", "canvas"), "the canvas")
            bare_times.append(time.perf_counter() - began)
            with contextlib.redirect_stdout(io.StringIO()):
                bare.stop()
    a, b = statistics.median(page_times), statistics.median(bare_times)
    print(f"page ready in chromium: maniplab gui {a:.2f} s, bare viser {b:.2f} s: "
          f"ratio {a / b:.1f}")


def replay_rates(repeats: int) -> None:
    spec = ml.builtin_spec("erector")
    runs = [ml.simulate(spec, inputs={"q6": ml.signals.sine(0.3, 0.5)}, duration=4.0,
                        initial={"dP": "gravity"}, overrides={"end_effector.mass": m})
            for m in (4000.0, 3000.0, 2000.0)]
    for count in (1, 3):
        rates = []
        with recording_server() as server:
            replay = Replay(server.scene, runs[:count], 30.0)
            for _ in range(repeats):
                began = time.perf_counter()
                for frame in range(replay.frames):
                    with server.atomic():
                        replay.show(frame)
                    server.flush()
                rates.append(replay.frames / (time.perf_counter() - began))
        rendered = []
        for _ in range(repeats):
            began = time.perf_counter()
            frames = ml.render(runs[0], width=640, height=360, fps=30.0, progress=False)
            rendered.append(len(frames) / (time.perf_counter() - began))
        a, b = statistics.median(rates), statistics.median(rendered)
        print(f"replay poses, {count} run(s): {a:.0f} frames/s; MuJoCo offscreen video "
              f"{b:.0f} frames/s: ratio {a / b:.1f}")
    page = Path(tempfile.mkdtemp()) / "replay.html"
    page.write_text(replay_html(runs[:2]))
    with recording_server() as server:
        empty = Path(tempfile.mkdtemp()) / "empty.html"
        empty.write_text(server.scene.as_html())
    with web.chromium(offline=True) as driver:
        driver.set_script_timeout(30)
        fps = {}
        for name, path in (("replay", page), ("empty", empty)):
            samples = []
            for _ in range(repeats):
                driver.get(path.as_uri())
                web.wait(lambda: driver.find_elements("css selector", "canvas"), "the canvas")
                time.sleep(1.0)
                samples.append(driver.execute_async_script(FRAME_RATE_JS))
            fps[name] = statistics.median(samples)
    print(f"HTML replay in headless chromium (software WebGL): {fps['replay']:.0f} frames/s; "
          f"empty viser scene {fps['empty']:.0f} frames/s: ratio {fps['replay'] / fps['empty']:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    startup(args.repeats)
    replay_rates(args.repeats)


if __name__ == "__main__":
    main()
