"""The Watch tab: the runs ticked in the Runs tab replayed in 3D with a timeline (play, pause,
scrub, speed), and exported as a self-contained HTML replay.

Playback runs on the server: a thread advances the timeline at :data:`FPS` frames per second of
wall time, and the timeline's own callback poses the arms, so scrubbing and playing are the same
path.
"""

from __future__ import annotations

import html
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from maniplab.errors import ManiplabError
from maniplab.gui.player import replay_html
from maniplab.gui.replay import Replay, stage
from maniplab.gui.runs import legend
from maniplab.gui.text import plain, warning
from maniplab.viz import palette

if TYPE_CHECKING:
    from maniplab.gui.app import Gui

FPS = 30.0
"""Frames per second of the replay, of run time and of wall time at speed 1."""

SPEEDS = ("0.1", "0.25", "0.5", "1", "2", "4")


class WatchTab:
    """The Watch tab of ``app``."""

    def __init__(self, app: Gui) -> None:
        self.app = app
        gui = app.server.gui
        gui.add_button("Show the ticked runs").on_click(lambda _: self.show())
        self.key = gui.add_html("")
        self.time = gui.add_slider("Time [s]", min=0.0, max=1.0, step=1.0 / FPS, initial_value=0.0)
        self.time.on_update(lambda _: self._seek())
        self.play_button = gui.add_button("Play")
        self.play_button.on_click(lambda _: self.toggle())
        self.speed = gui.add_dropdown("Speed", SPEEDS, initial_value="1")
        smooth = gui.add_button(
            "Smooth player", hint="the ticked runs in maniplab's own WebGL player, here in the "
            "panel (widen the panel, or ⛶ for full screen): it plays at the page's frame rate "
            "where the 3D view above is limited by the scene's drawing")
        smooth.on_click(lambda _: self.smooth())
        app.job_buttons.append(smooth)
        self.player = gui.add_html("", visible=False)
        export = gui.add_button("Export HTML replay")
        export.on_click(lambda event: self.export(event.client))
        app.job_buttons.append(export)
        gui.add_button("Back to the arm").on_click(lambda _: self.hide())
        self.message = gui.add_markdown("")
        # Nothing in maniplab's scenes casts a shadow (the arms are drawn without), yet viser's
        # default light renders its shadow maps at every frame the page draws: more than half
        # of a frame on a software WebGL (SwiftShader, a machine without GPU) while a replay
        # plays. Without them the scene looks the same.
        app.server.scene.configure_default_lights(enabled=True, cast_shadow=False)
        self.replay: Replay | None = None
        self.playing = threading.Event()
        self._lock = threading.Lock()
        threading.Thread(target=self._play, daemon=True, name="maniplab-gui: playback").start()

    def show(self) -> None:
        """Replay the runs ticked in the Runs tab (the first solid, the others as ghosts)."""
        names = self.app.runs.selected()
        try:
            if not names:
                raise ManiplabError("tick the runs to watch in the Runs tab")
            runs = [self.app.workspace.load_run(n) for n in names]
            with self._lock:
                self._clear()
                replay = Replay(self.app.server.scene, runs, FPS)
                self.replay = replay
        except (ManiplabError, OSError) as exc:
            self.message.content = warning(exc)
            return
        self._set_arm_visible(False)
        stage(self.app.server, [run.spec for run in runs], replay.bounds())
        self.key.content = _key(legend(runs, names))
        self.time.min, self.time.max = float(replay.times[0]), float(replay.times[-1])
        self.time.step = 1.0 / replay.fps
        self.time.value = float(replay.times[0])
        self.message.content = plain(f"{len(runs)} run(s), {replay.frames} frames: blue joints "
                                     "stick, red ones are at a limit")

    def hide(self) -> None:
        """Take the replay away and show the arm being configured."""
        self.playing.clear()
        self.play_button.label = "Play"
        with self._lock:
            shown = self.replay is not None
            self._clear()
        self.key.content = ""
        self.player.visible, self.player.content = False, ""
        self._set_arm_visible(True)
        if shown:  # the floor and camera of the arm being configured again
            arm = self.app.configure.arm3d
            stage(self.app.server, [self.app.spec], arm.bounds() if arm is not None else None)

    def _clear(self) -> None:
        if self.replay is not None:
            self.replay.remove()
            self.replay = None

    def _set_arm_visible(self, visible: bool) -> None:
        arm = self.app.configure.arm3d
        if arm is not None:
            arm.set_visible(visible)

    def toggle(self) -> None:
        """Play or pause."""
        if self.playing.is_set():
            self.playing.clear()
            self.play_button.label = "Play"
        elif self.replay is not None:
            if self.time.value >= self.time.max:
                self.time.value = self.time.min
            self.playing.set()
            self.play_button.label = "Pause"

    def _seek(self) -> None:
        with self._lock:
            if self.replay is not None:
                with self.app.server.atomic():
                    self.replay.show(self.replay.frame_at(float(self.time.value)))

    def _play(self) -> None:
        while True:
            self.playing.wait()
            began, start = time.monotonic(), float(self.time.value)
            while self.playing.is_set():
                time.sleep(1.0 / FPS)
                t = start + (time.monotonic() - began) * float(self.speed.value)
                if t >= self.time.max:
                    self.time.value = self.time.max
                    self.playing.clear()
                    self.play_button.label = "Play"
                    break
                self.time.value = round(t * FPS) / FPS

    def export(self, client: Any = None) -> None:
        """Write the ticked runs' replay as an offline HTML page and send it to ``client`` (the
        page that asked)."""

        def done(names: list[str], page: str) -> str:
            path = self.app.download(f"replay-{'-'.join(names)}"[:64], ".html", page, client)
            return f"replay written to {path} and sent to the browser"

        self._ticked_replay("export", "exporting the replay", done)

    def smooth(self) -> None:
        """Show the ticked runs in the player of the HTML replays, framed in the panel."""

        def done(names: list[str], page: str) -> str:
            self.player.content = _framed(page)
            self.player.visible = True
            count = len(names)
            return f"the smooth player holds {count} run{'s' if count > 1 else ''}"

        self._ticked_replay("play", "preparing the smooth player", done)

    def _ticked_replay(self, verb: str, job: str, done: Callable[[list[str], str], str]) -> None:
        """Make the ticked runs' HTML replay in a job named ``job``, then ``done(names, page)``
        says what became of it; with no run ticked, ask to tick the runs to ``verb``."""
        names = self.app.runs.selected()
        if not names:
            self.message.content = warning(f"tick the runs to {verb} in the Runs tab")
            return

        def work() -> str:
            return replay_html([self.app.workspace.load_run(n) for n in names], FPS, names)

        self.app.jobs.start(job, work, lambda page: done(names, page), self._say)

    def _say(self, text: str) -> None:
        bad = "failed" in text or "busy" in text or "stopped" in text
        self.message.content = warning(text) if bad else plain(text)

    def clear_messages(self) -> None:
        """Hide the tab's message."""
        self.message.content = ""


def _framed(page: str) -> str:
    """An HTML page in a frame as wide as the panel (its own document: its script runs)."""
    return (f"<iframe id='ml-player' title='smooth player' srcdoc=\"{html.escape(page)}\" "
            "allow='fullscreen' style='width:100%;height:min(70vh,560px);border:0;"
            "border-radius:4px'></iframe>")


def _key(labels: list[str]) -> str:
    """The colour of each run, as HTML."""
    items = []
    for k, label in enumerate(labels):
        r, g, b = palette.to_uint8(palette.run_colour(k))
        shape = "solid" if k == 0 else "ghost"
        items.append(f"<span style='color:rgb({r},{g},{b})'>■</span> {html.escape(label)} "
                     f"({shape})")
    return "<div style='font-size:12px'>" + "<br>".join(items) + "</div>"
