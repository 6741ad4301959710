"""The GUI: a local web page with four tabs on one 3D scene (viser: a Python-driven three.js
page over a websocket).

* Configure: the arm as a table of joints, edited field by field; the 3D arm follows.
* Simulate: inputs per joint, the headline parameters, Run / Stop; a closed-loop move to a target.
* Runs: the stored runs (rename, delete) and their signals overlaid.
* Watch: runs replayed in 3D with a timeline; exported as an offline HTML page.

Every action calls the public API the command line calls (``simulate``, ``run_move``,
``to_mjcf``, ``export_model``, ``viz.plots.compare``); the GUI adds only the page. Its widgets
live on the server and are shared by every tab of the browser, so two tabs show the same state.

Only the page's own address with the secret token opens it (:mod:`maniplab.gui.access`), and
what the page sends is checked and paced on the server (:mod:`maniplab.gui.guard`). Every text
shown on the page is escaped (:mod:`maniplab.gui.text`).
"""

from __future__ import annotations

import contextlib
import io
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from maniplab.gui.guard import guard
from maniplab.gui.tabs import tab_watcher
from maniplab.gui.text import plain
from maniplab.gui.workspace import Workspace
from maniplab.spec import ManipulatorSpec

LOCALHOST = ("127.0.0.1", "localhost", "::1")
TABS = ("Configure", "Simulate", "Runs", "Watch")
IDLE_STOP = "Stop (no job running)"


class Gui:
    """The server and its page.

    Args:
        spec: the arm shown first.
        workspace: the folder the page reads and writes (:class:`Workspace`).
        host: interface to listen on (default localhost only).
        port: TCP port (the next free one above it when taken).
        token: the secret the page's address carries (default: a fresh random one).
        controllers: your own controllers for closed-loop moves, name -> factory
            ``factory(spec, move) -> controller`` (offered beside the cascade and the PID
            baseline; loaded by whoever starts the server, never named by the page).
    """

    def __init__(self, spec: ManipulatorSpec, workspace: str | Path, *, host: str = "127.0.0.1",
                 port: int = 8080, token: str | None = None,
                 controllers: dict[str, Callable[..., Any]] | None = None) -> None:
        import viser

        from maniplab.gui.access import Access, hooked, new_token
        from maniplab.gui.configure import ConfigureTab
        from maniplab.gui.jobs import Jobs
        from maniplab.gui.runs import RunsTab
        from maniplab.gui.simulate import SimulateTab
        from maniplab.gui.watch import WatchTab

        self.workspace = Workspace(workspace)
        self.spec = spec
        self.lock = threading.RLock()  # callbacks come from viser's thread pool
        self._spec_listeners: list[Callable[[], None]] = []
        self._run_listeners: list[Callable[[], None]] = []
        self._unit_listeners: list[Callable[[], None]] = []
        self.token = token or new_token()
        self.controllers = dict(controllers or {})
        self.said = "idle"
        with contextlib.redirect_stdout(io.StringIO()), hooked(Access(self.token, [host])):
            self.server = viser.ViserServer(host=host, port=port, label="maniplab", verbose=False)
        self.guard = guard(self.server, self._bug)
        gui = self.server.gui
        gui.configure_theme(control_width="large", show_logo=False, show_share_button=False)
        gui.main_panel.dock_right()  # beside the 3D view, not over it: the arm framed is seen
        self.job_buttons: list[Any] = []  # disabled while a job runs (Run, Run move, exports)
        self.jobs = Jobs(self._report, self._busy)
        with gui.add_folder("Job", order=0):
            self.status = gui.add_markdown("idle")
            self.progress = gui.add_progress_bar(0.0, visible=False)
            # Stop is shown only while a job runs (red); idle, a disabled grey Stop stands in
            # its place ("Stop (no job running)"), so the button that stops is never disabled
            self.stop_button = gui.add_button("Stop", color="red", visible=False,
                                              hint="stop the running job; nothing of it is "
                                                   "stored")
            self.stop_idle = gui.add_button(IDLE_STOP, disabled=True, hint="no job runs")
            self.tab = TABS[0]
            tab_watcher(gui, TABS, self._switched)
        self.stop_button.on_click(lambda _: self.jobs.stop())
        tabs = gui.add_tab_group(order=1)
        with tabs.add_tab("Configure"):
            self.configure = ConfigureTab(self)
        with tabs.add_tab("Simulate"):
            self.simulate = SimulateTab(self)
        with tabs.add_tab("Runs"):
            self.runs = RunsTab(self)
        with tabs.add_tab("Watch"):
            self.watch = WatchTab(self)

    @property
    def address(self) -> str:
        """The page's address without the token."""
        host = self.server.get_host()
        shown = "127.0.0.1" if host in ("0.0.0.0", "::") else host
        shown = f"[{shown}]" if ":" in shown else shown
        return f"http://{shown}:{self.server.get_port()}"

    @property
    def url(self) -> str:
        """The page's address with its token: the one to open."""
        return f"{self.address}/?token={self.token}"

    # --- shared state ---------------------------------------------------------------------------

    def on_spec(self, listener: Callable[[], None]) -> None:
        """Call ``listener()`` after the arm changes."""
        self._spec_listeners.append(listener)

    def on_runs(self, listener: Callable[[], None]) -> None:
        """Call ``listener()`` after the stored runs change."""
        self._run_listeners.append(listener)

    def on_units(self, listener: Callable[[], None]) -> None:
        """Call ``listener()`` after the user chose other units (``configure.units``)."""
        self._unit_listeners.append(listener)

    def units_changed(self) -> None:
        """Tell every tab that the units shown changed."""
        with self.lock:
            for listener in self._unit_listeners:
                listener()

    def set_spec(self, spec: ManipulatorSpec) -> None:
        """Make ``spec`` (valid) the arm of every tab."""
        with self.lock:
            self.spec = spec
            for listener in self._spec_listeners:
                listener()

    def runs_changed(self) -> None:
        """Tell every tab that runs were stored, renamed or deleted."""
        with self.lock:
            for listener in self._run_listeners:
                listener()

    def say(self, text: str) -> None:
        """Show one status line (as text: escaped, on one line)."""
        self.said = " ".join(text.split())
        self.status.content = plain(text)

    def _busy(self, busy: bool) -> None:
        """A job started (True) or ended: Stop enabled (red) only while one runs, the buttons that
        start jobs disabled meanwhile."""
        # in this order, so that a page showing Stop (or the idle stand-in) shows the rest too
        for button in self.job_buttons:
            button.disabled = busy
        if not busy:
            self.progress.visible = False
        (self.stop_idle if busy else self.stop_button).visible = False
        (self.stop_button if busy else self.stop_idle).visible = True

    def _switched(self, tab: str) -> None:
        """The page shows ``tab``: the other tabs' messages cleared, each tab its own scene (the
        Watch replay only in Watch)."""
        with self.lock:
            left, self.tab = self.tab, tab
            if tab == left:
                return
            for part in (self.configure, self.simulate, self.runs, self.watch):
                part.clear_messages()
            if left == "Watch":
                self.watch.hide()
            if self.simulate.gizmo is not None:  # the move's target: a control of Simulate only
                self.simulate.gizmo.visible = tab == "Simulate"
            if not self.jobs.busy:
                self.say("idle")

    def _report(self, text: str, fraction: float | None) -> None:
        self.say(text)
        self.progress.visible = fraction is not None
        if fraction is not None:
            self.progress.value = round(100.0 * fraction, 1)

    def _bug(self, exc: BaseException) -> None:
        """Show an error raised in a callback (its traceback is on stderr)."""
        self.say(f"⚠ a maniplab bug (traceback on the server's stderr): {type(exc).__name__}: "
                 f"{exc}")

    def download(self, name: str, suffix: str, content: str | bytes, client: Any) -> Path:
        """Keep ``content`` in the workspace's exports and send it as a download to ``client``
        (the page that asked: a viser ClientHandle; None sends nothing); returns the file."""
        path = self.workspace.export(name, suffix, content)
        if client is not None and client.client_id in self.server.get_clients():
            client.send_file_download(path.name, path.read_bytes())
        return path

    def close(self) -> None:
        """Stop the running job and the server."""
        self.jobs.stop()
        with contextlib.redirect_stdout(io.StringIO()):
            self.server.stop()


def serve(spec: ManipulatorSpec, workspace: str | Path, *, host: str = "127.0.0.1",
          port: int = 8080, token: str | None = None,
          controllers: dict[str, Callable[..., Any]] | None = None) -> Gui:
    """Start the GUI server (it runs in background threads until :meth:`Gui.close`)."""
    return Gui(spec, workspace, host=host, port=port, token=token, controllers=controllers)


def exposed(host: str) -> bool:
    """Whether ``host`` lets other machines reach the page."""
    return host not in LOCALHOST
