"""The Runs tab: the runs stored in the workspace (rename, delete) and their signals overlaid.

The plot is :func:`maniplab.viz.plots.compare`'s, as ``maniplab compare`` draws it: one row per
signal, with units, and a legend naming the parameters in which the runs differ.
"""

from __future__ import annotations

import html
import io
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from maniplab.errors import ManiplabError
from maniplab.gui.text import plain, warning
from maniplab.sim import params
from maniplab.sim.run import Run
from maniplab.viz.compare import parameters

if TYPE_CHECKING:
    from maniplab.gui.app import Gui

SIGNALS = {
    "q": "q: joint position", "qd": "q̇: joint velocity", "dP": "ΔP: load pressure",
    "Q": "Q: valve flow", "iv": "valve current", "tau_fric": "friction force",
    "mode": "friction mode", "tracking_error": "tracking error",
}


def legend(runs: list[Run], names: list[str]) -> list[str]:
    """Legend entries: the parameters in which the runs differ, else their names."""
    return params.labels([parameters(run) for run in runs], names)


def runs_table(workspace: Any, names: list[str]) -> str:
    """The stored runs as an HTML table: name, duration, kind, health verdict."""
    rows = []
    for name in names:
        try:
            run = workspace.load_run(name)
            kind = "closed loop" if "e_x" in run else "open loop"
            cells = (name, f"{float(run.t[-1]):.3g} s", kind, run.health.verdict)
        except (ManiplabError, OSError) as exc:
            cells = (name, "–", "unreadable", str(exc))
        rows.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells) + "</tr>")
    if not rows:
        return "<p style='font-size:12px'>No runs yet: run one in the Simulate tab.</p>"
    return ("<table id='ml-runs' style='border-collapse:collapse;font-size:11px'>"
            "<tr><th>run</th><th>duration</th><th>kind</th><th>health</th></tr>"
            + "".join(rows) + "</table>")


class RunsTab:
    """The Runs tab of ``app``."""

    def __init__(self, app: Gui) -> None:
        self.app = app
        gui = app.server.gui
        self.table = gui.add_html("")
        self.pick_folder = gui.add_folder("Runs to compare and watch")
        self.picks: dict[str, Any] = {}
        with gui.add_folder("Rename or delete", expand_by_default=False):
            self.chosen = gui.add_dropdown("Run", ["-"])
            self.new_name = gui.add_text("New name", "")
            gui.add_button("Rename").on_click(lambda _: self.rename())
            gui.add_button("Delete", color="red").on_click(lambda _: self.delete())
        with gui.add_folder("Signals"):
            self.signals = {key: gui.add_checkbox(label, key in ("q", "dP"))
                            for key, label in SIGNALS.items()}
        gui.add_button("Plot selected runs").on_click(lambda _: self.plot())
        self.message = gui.add_markdown("")
        self.figure = gui.add_image(np.full((8, 8, 3), 255, np.uint8), label="comparison",
                                    visible=False)
        app.on_runs(self.refresh)
        self.refresh()

    def refresh(self) -> None:
        """Show the runs now stored (after a restart too: the workspace is the record)."""
        names = self.app.workspace.runs()
        self.table.content = runs_table(self.app.workspace, names)
        if list(self.picks) != names:
            chosen = {n for n, box in self.picks.items() if box.value}
            for box in self.picks.values():
                box.remove()
            with self.pick_folder:
                self.picks = {n: self.app.server.gui.add_checkbox(n, n in chosen) for n in names}
        self.chosen.options = names or ["-"]

    def selected(self) -> list[str]:
        """Names of the runs ticked."""
        return [n for n, box in self.picks.items() if box.value]

    def rename(self) -> None:
        """Rename the chosen run."""
        old, new = self.chosen.value, self.new_name.value.strip()
        self._change(lambda: self.app.workspace.rename_run(old, new),
                     f"renamed '{old}' to '{new}'")

    def delete(self) -> None:
        """Delete the chosen run."""
        name = self.chosen.value
        self._change(lambda: self.app.workspace.delete_run(name), f"deleted '{name}'")

    def _change(self, action: Callable[[], None], done: str) -> None:
        """Change the stored runs by ``action()``; say ``done``, or the one-line error."""
        try:
            action()
        except (ManiplabError, OSError) as exc:
            self.message.content = warning(exc)
            return
        self.message.content = plain(done)
        self.app.runs_changed()

    def plot(self) -> None:
        """Overlay the chosen signals of the runs ticked."""
        from maniplab.viz.plots import compare

        names = self.selected()
        signals = [key for key, box in self.signals.items() if box.value]
        try:
            if not names or not signals:
                raise ManiplabError("tick at least one run and one signal")
            runs = [self.app.workspace.load_run(n) for n in names]
            figure = compare(runs, signals, labels=legend(runs, names))
        except (ManiplabError, OSError, ValueError) as exc:
            self.message.content = warning(exc)
            return
        self.figure.image = _pixels(figure)
        self.figure.visible = True
        self.message.content = plain(f"{len(runs)} run(s): {', '.join(signals)}")


def _pixels(figure: Any) -> np.ndarray:
    """A matplotlib figure as an RGB image, shape (H, W, 3)."""
    from PIL import Image

    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90)
    return np.asarray(Image.open(buffer).convert("RGB"))
