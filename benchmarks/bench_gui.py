"""The GUI's start-up, edit latency and replay frame rates, each against a peer in the same run.

Run: .venv/bin/python benchmarks/bench_gui.py [--repeats 5]   (needs chromium and chromedriver)

Printed (medians over the repeats):

* start-up: ``maniplab gui``'s server (``Gui(erector)``: viser server, the four tabs, the 3D
  erector) ready to serve, against a bare ``viser.ViserServer()`` (the peer); and the page in
  headless chromium until the joint table shows, against the bare viser page until its canvas
  shows.
* edit latency: a body mass typed in Configure, from the last keystroke to the joint table
  showing it (clocked in the page), against a plain text field's value reaching the server
  (``--only edit``).
* replay, server side: frames per second at which the Watch tab poses the erector (one run, and
  three runs as ghosts), against MuJoCo's offscreen renderer drawing the same run's frames
  (``ml.render``, 640x360, the videos' path; the peer).
* replay, browser side: frames per second the exported HTML replay draws while it plays in
  headless chromium on the software (SwiftShader) WebGL of a machine without GPU (maniplab's own
  player, and viser's recording player it replaced), against the same browser's frame rate on an
  empty viser scene (``--only html`` runs this part alone).
* the live Watch tab, browser side: frames per second the GUI's page draws in headless chromium
  (software WebGL) while the server plays two erector runs (one solid, one ghost) at 30 frames/s,
  against the same page with the replay shown and paused; and Watch's smooth player (the HTML
  replays' player in the panel) playing the same runs (``--only watch``).
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
from maniplab.gui.player import replay_html
from maniplab.gui.replay import Replay, recording_server, stage

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
    html_replay_rates(runs[:2], repeats)


PLAYING_RATE_JS = """
const done = arguments[arguments.length - 1];
const player = window.maniplabPlayer;
const f0 = player.frame, d0 = player.drawn, t0 = performance.now();
let frames = 0, playing = player.playing;
function tick() {
  frames++; playing = playing && player.playing;
  if (performance.now() - t0 < 3000) { requestAnimationFrame(tick); return; }
  const s = (performance.now() - t0) / 1000;
  done({raf: frames / s, drawn: (player.drawn - d0) / s, advanced: player.frame !== f0, playing});
}
requestAnimationFrame(tick);
"""


def _viser_replay_page(runs: list) -> str:
    """The HTML replay as it was before maniplab's own player: viser's recording of the scene
    updates, played by viser's player (the "before" of the HTML replay's frame rate)."""
    with recording_server() as server:
        replay = Replay(server.scene, runs, 30.0)
        stage(server, [run.spec for run in runs], replay.bounds())
        recorder = server.get_scene_serializer()
        for frame in range(1, replay.frames):
            recorder.insert_sleep(1.0 / replay.fps)
            replay.show(frame)
        recorder.insert_sleep(1.0 / replay.fps)
        return str(recorder.as_html())


def _rate(driver, path: Path, repeats: int, ours: bool) -> float:
    """Median frames/s over ``repeats`` 3-s windows while the page at ``path`` plays: for our
    player the frames it drew, checked to be playing and advancing; else rAF callbacks."""
    samples = []
    for _ in range(repeats):
        driver.get(path.as_uri())
        web.wait(lambda: driver.find_elements("css selector", "canvas"), "the canvas")
        if ours:
            web.wait(lambda: driver.execute_script("return window.maniplabPlayer"), "the player")
            driver.execute_script("maniplabPlayer.seek(maniplabPlayer.t0); maniplabPlayer.play()")
            time.sleep(1.0)
            got = driver.execute_async_script(PLAYING_RATE_JS)
            assert got["playing"] and got["advanced"], f"the replay did not play: {got}"
            samples.append(got["drawn"])
        else:
            time.sleep(1.0)
            samples.append(driver.execute_async_script(FRAME_RATE_JS))
    return statistics.median(samples)


def html_replay_rates(runs: list | None, repeats: int) -> None:
    """The exported HTML replay of ``runs`` playing in headless chromium (software WebGL): our
    player, and viser's recording player it replaced, against the same browser on an empty
    viser scene (the peer). Without runs: the erector's two of :func:`replay_rates`."""
    if runs is None:
        spec = ml.builtin_spec("erector")
        runs = [ml.simulate(spec, inputs={"q6": ml.signals.sine(0.3, 0.5)}, duration=4.0,
                            initial={"dP": "gravity"}, overrides={"end_effector.mass": m})
                for m in (4000.0, 3000.0)]
    folder = Path(tempfile.mkdtemp())
    pages = {"ours": folder / "replay.html", "viser": folder / "viser.html",
             "empty": folder / "empty.html"}
    pages["ours"].write_text(replay_html(runs))
    pages["viser"].write_text(_viser_replay_page(runs))
    with recording_server() as server:
        pages["empty"].write_text(server.scene.as_html())
    with web.chromium(offline=True) as driver:
        driver.set_script_timeout(30)
        fps = {name: _rate(driver, path, repeats, name == "ours") for name, path in pages.items()}
    for name, what in (("ours", "maniplab's player"), ("viser", "viser's player (before)")):
        print(f"HTML replay in headless chromium (software WebGL), {what}: {fps[name]:.1f} "
              f"frames/s; empty viser scene {fps['empty']:.0f} frames/s: ratio "
              f"{fps[name] / fps['empty']:.2f}")


def watch_rates(repeats: int, count: int = 2) -> None:
    """The live Watch tab in headless chromium: the page's frame rate while the server plays the
    erector's runs (the first solid, the others as ghosts), against the same page with the same
    replay shown but paused (the peer)."""
    spec = ml.builtin_spec("erector")
    folder = tempfile.mkdtemp()
    app = Gui(spec, folder, port=_port())
    try:
        for k, mass in enumerate((4000.0, 3000.0, 2000.0)[:count]):
            run = ml.simulate(spec, inputs={"q6": ml.signals.sine(0.3, 0.5),
                                            "q2": ml.signals.sine(0.2, 0.25)},
                              duration=3.0 * repeats + 4.0, initial={"dP": "gravity"},
                              overrides={"end_effector.mass": mass})
            app.workspace.save_run(run, f"run{k}")
        app.runs_changed()
        for box in app.runs.picks.values():
            box.value = True
        with web.chromium() as driver:
            driver.set_script_timeout(30)
            driver.get(app.url)
            web.wait(lambda: web.visible(driver, "//table[@id='ml-joints']"), "the table")
            web.tab(driver, "Watch")
            app.watch.show()
            assert app.watch.replay is not None, app.watch.message.content
            time.sleep(2.0)
            idle = [driver.execute_async_script(FRAME_RATE_JS) for _ in range(repeats)]
            app.watch.toggle()
            time.sleep(0.5)
            playing = []
            for _ in range(repeats):
                playing.append(driver.execute_async_script(FRAME_RATE_JS))
            app.watch.toggle()
            smooth = _smooth_player_rates(driver, app, repeats)
    finally:
        app.close()
    a, b, c = statistics.median(playing), statistics.median(idle), statistics.median(smooth)
    print(f"live Watch tab in headless chromium (software WebGL), {count} run(s) playing: "
          f"{a:.1f} frames/s; the same page paused {b:.1f} frames/s: ratio {a / b:.2f}")
    print(f"Watch's smooth player (the HTML replays' player in the panel), {count} run(s) "
          f"playing: {c:.1f} frames/s: ratio {c / b:.2f} to the paused page")


def _smooth_player_rates(driver, app: Gui, repeats: int) -> list[float]:
    """Frame rates counted inside Watch's smooth player while it plays (its frame advancing)."""
    app.watch.smooth()
    frame = web.wait(lambda: driver.find_element("id", "ml-player"), "the smooth player")
    driver.switch_to.frame(frame)
    try:
        web.wait(lambda: driver.execute_script("return window.maniplabPlayer"), "the player")
        time.sleep(1.0)
        rates = []
        for _ in range(repeats):
            first = driver.execute_script("return maniplabPlayer.frame")
            rates.append(driver.execute_async_script(FRAME_RATE_JS))
            assert driver.execute_script("return maniplabPlayer.playing"), "not playing"
            assert driver.execute_script("return maniplabPlayer.frame") != first, "no progress"
        return rates
    finally:
        driver.switch_to.default_content()


EDIT_CLOCKS_JS = """
window.mlTyped = null; window.mlShown = null;
document.addEventListener('input', () => { if (window.mlShown === null) window.mlTyped = Date.now(); },
                          true);
const want = arguments[0];
if (want !== null) {
  const seen = () => { const t = document.getElementById('ml-joints');
                       return t !== null && t.textContent.includes(want); };
  new MutationObserver((_, observer) => {
    if (window.mlTyped !== null && window.mlShown === null && seen()) {
      window.mlShown = Date.now(); observer.disconnect(); } })
    .observe(document.body, {childList: true, subtree: true, characterData: true});
}
"""
"""Page-side clocks of an edit: the last keystroke typed into a field (its input event), and when
the joint table first showed the value ``arguments[0]`` (null: only the keystrokes)."""


def edit_latency(repeats: int) -> None:
    """A valid edit typed in the page (a body mass in Configure): from its last keystroke to the
    joint table showing the new value, clocked in the page; against the same typing in a plain text
    field (Simulate's run name) from its last keystroke to the server holding the value (viser's
    round trip: the peer; the page's and the server's clocks are the same machine's)."""
    spec = ml.builtin_spec("erector")
    app = Gui(spec, tempfile.mkdtemp(), port=_port())
    held: list[float] = []
    app.simulate.name.on_update(lambda _: held.append(time.time()))
    ours, peer = [], []
    try:
        with web.chromium() as driver:
            driver.get(app.url)
            web.wait(lambda: web.visible(driver, "//table[@id='ml-joints']"), "the table")
            for k in range(repeats):
                mass = f"{1800 + k}"
                driver.execute_script(EDIT_CLOCKS_JS, mass)
                web.type_into(driver, "Body mass [kg]", mass)
                shown = web.wait(lambda: driver.execute_script("return window.mlShown"),
                                 "the table")
                ours.append((shown - driver.execute_script("return window.mlTyped")) / 1000.0)
            web.tab(driver, "Simulate")
            for k in range(repeats):
                driver.execute_script(EDIT_CLOCKS_JS, None)
                held.clear()
                web.type_into(driver, "Run name", f"run{k}")
                web.wait(lambda n=f"run{k}": app.simulate.name.value == n, "the server")
                typed = driver.execute_script("return window.mlTyped") / 1000.0
                peer.append(max(held[-1] - typed, 0.0))
    finally:
        app.close()
    a, b = statistics.median(ours), statistics.median(peer)
    print(f"edit to the joint table (last keystroke to the value shown): {a * 1000:.0f} ms; a text field "
          f"to the server (last keystroke to its callback): {b * 1000:.0f} ms: ratio {a / max(b, 1e-3):.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--only", choices=("startup", "edit", "replay", "html", "watch"),
                        help="run only this part")
    args = parser.parse_args()
    if args.only in (None, "startup"):
        startup(args.repeats)
    if args.only in (None, "edit"):
        edit_latency(args.repeats)
    if args.only in (None, "replay"):
        replay_rates(args.repeats)
    if args.only == "html":
        html_replay_rates(None, args.repeats)
    if args.only in (None, "watch"):
        watch_rates(args.repeats)


if __name__ == "__main__":
    main()
