"""The Runs tab: the runs stored in the workspace (rename, delete) and their signals overlaid.

The plot is :func:`maniplab.viz.plots.compare`'s, as ``maniplab compare`` draws it: one row per
signal, with units, and a legend naming the parameters in which the runs differ.
"""

from __future__ import annotations

import html
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from maniplab.errors import ManiplabError
from maniplab.gui.text import Note, plain, warning
from maniplab.sim.run import Run

if TYPE_CHECKING:
    from maniplab.gui.app import Gui

SIGNALS = {
    "q": "q: joint position", "qd": "q̇: joint velocity", "dP": "ΔP: load pressure",
    "Q": "Q: valve flow", "iv": "valve current", "tau_fric": "friction force",
    "mode": "friction mode", "tracking_error": "tracking error",
}


def legend(runs: list[Run], names: list[str]) -> list[str]:
    """Legend entries: each run's name and the parameters in which the runs differ."""
    from maniplab.gui.plot import legend as named

    return named(runs, names)


def run_summary(workspace: Any, name: str) -> str:
    """One stored run as HTML, shown under its tick box: duration, kind, health verdict; a
    closed-loop move's record (target, asked and actual duration, controller, errors, findings)
    expandable."""
    try:
        run = workspace.load_run(name)
    except (ManiplabError, OSError) as exc:
        return f"<div class='ml-run' style='font-size:11px'>unreadable: {html.escape(str(exc))}</div>"
    kind = "closed loop" if "e_x" in run else "open loop"
    line = f"{float(run.t[-1]):.3g} s · {kind} · health {run.health.verdict}"
    move = run.meta.get("move")
    details = ""
    if isinstance(move, dict):
        from maniplab.gui.simulate import move_lines

        target = ", ".join(f"{float(x):.3f}" for x in move.get("target", []))
        rows = [("target [m]", target), ("controller", str(move.get("controller", "?"))),
                ("duration asked [s]", f"{float(move.get('asked_duration', 0.0)):g}"),
                ("duration run [s]", f"{float(move.get('duration', 0.0)):.3g}"),
                ("stretched", "yes" if move.get("stretched") else "no")]
        try:
            said = move_lines(move)
        except (KeyError, TypeError, ValueError, IndexError):
            said = []
        cells = "".join(f"<tr><td>{html.escape(k)}</td><td>{html.escape(v)}</td></tr>"
                        for k, v in rows)
        notes = "".join(f"<li>{html.escape(x)}</li>" for x in said)
        stretched = " · <b>stretched</b>" if move.get("stretched") else ""
        details = (f"<details class='ml-move'><summary>move to [{html.escape(target)}] m{stretched}"
                   f"</summary><table style='font-size:11px'>{cells}</table>"
                   f"<ul style='margin:0;padding-left:1.2em'>{notes}</ul></details>")
    findings = list(dict.fromkeys(run.health.lines()))
    if findings and not isinstance(move, dict):  # a move lists them in its record
        items = "".join(f"<li>{html.escape(x)}</li>" for x in findings)
        details += (f"<details class='ml-health'><summary>{len(findings)} finding(s)</summary>"
                    f"<ul style='margin:0;padding-left:1.2em'>{items}</ul></details>")
    return (f"<div class='ml-run' data-run='{html.escape(name, quote=True)}' "
            f"style='font-size:11px;margin:-6px 0 6px 2.2em;color:#555'>{html.escape(line)}"
            f"{details}</div>")


class RunsTab:
    """The Runs tab of ``app``."""

    def __init__(self, app: Gui) -> None:
        self.app = app
        gui = app.server.gui
        self.pick_folder = gui.add_folder("Stored runs: tick to compare and watch")
        with self.pick_folder:
            self.empty = gui.add_markdown("No runs yet: run one in the Simulate tab.")
        self.picks: dict[str, Any] = {}
        self._summaries: dict[str, Any] = {}
        with gui.add_folder("Rename or delete", expand_by_default=False):
            self.chosen = gui.add_dropdown("Run", ["-"])
            self.new_name = gui.add_text("New name", "")
            gui.add_button("Rename").on_click(lambda _: self.rename())
            gui.add_button("Delete", color="red").on_click(lambda _: self.delete())
            self.change_note = Note(gui)
        with gui.add_folder("Signals"):
            self.signals = {key: gui.add_checkbox(label, key in ("q", "dP"))
                            for key, label in SIGNALS.items()}
        gui.add_button("Plot selected runs").on_click(lambda _: self.plot())
        self.message = gui.add_markdown("")
        self.pane: Any = None  # the plot pane: a window over the 3D view, made on the first plot
        self.plotly: Any = None
        self.plotted: tuple[list[str], list[str]] = ([], [])  # runs, signals
        app.on_runs(self.refresh)
        self.refresh()

    def refresh(self) -> None:
        """Show the runs now stored, each once: its tick box and, under it, its summary (after a
        restart too: the workspace is the record)."""
        names = self.app.workspace.runs()
        if list(self.picks) != names:
            chosen = {n for n, box in self.picks.items() if box.value}
            for handle in (*self.picks.values(), *self._summaries.values()):
                handle.remove()
            self.picks, self._summaries = {}, {}
            with self.pick_folder:
                for n in names:
                    self.picks[n] = self.app.server.gui.add_checkbox(n, n in chosen)
                    self._summaries[n] = self.app.server.gui.add_html(
                        run_summary(self.app.workspace, n))
        self.empty.visible = not names
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
            self.change_note(f"⚠ {exc}")
            return
        self.change_note(done)
        self.app.runs_changed()

    def clear_messages(self) -> None:
        """Hide the tab's messages (the plot stays)."""
        self.change_note.clear()
        self.message.content = ""

    def plot(self) -> None:
        """Overlay the chosen signals of the runs ticked in the plot pane: every joint in its
        own subplot with its unit, zoom, pan and a data cursor, exports to PNG, SVG and CSV."""
        from maniplab.gui.plot import figure, panels

        names = self.selected()
        signals = [key for key, box in self.signals.items() if box.value]
        try:
            if not names or not signals:
                raise ManiplabError("tick at least one run and one signal")
            runs = [self.app.workspace.load_run(n) for n in names]
            fig = figure(runs, names, signals, self.app.configure.units)
        except (ManiplabError, OSError, ValueError) as exc:
            self.message.content = warning(exc)
            return
        rows = max(p.row for p in panels(runs, signals))
        height = 190 * rows + 110
        aspect = height / (PANE_WIDTH - 30)  # viser's page draws it height = width * aspect
        self._show_pane(fig, aspect)
        self.plotted = (names, signals)
        self.message.content = plain(f"{len(runs)} run(s): {', '.join(signals)}, in the plot "
                                     "pane (drag to zoom, double-click to reset)")

    def _show_pane(self, fig: Any, aspect: float) -> None:
        gui = self.app.server.gui
        if self.pane is None:
            self.pane = gui.add_panel()
            with self.pane.add_tab("Plot"):
                self.plotly = gui.add_plotly(fig, aspect=aspect, config=PLOT_CONFIG)
                exports = gui.add_button_group("Download", ("PNG", "SVG", "CSV"),
                                               hint="the panels as an image, every sample as CSV")
                exports.on_click(lambda event: self.export(str(event.target.value).lower(),
                                                           event.client))
                self.export_note = Note(gui)
                gui.add_button("Close the plot").on_click(lambda _: self.close_pane())
        else:
            self.plotly.figure = fig
            self.plotly.aspect = aspect
            self.pane.visible = True
        self.pane.float(x=12, y=12, width=PANE_WIDTH)

    def close_pane(self) -> None:
        """Take the plot pane away (the next plot brings it back)."""
        if self.pane is not None:
            self.pane.visible = False

    def export(self, fmt: str, client: Any = None) -> None:
        """Send the plotted runs and signals as PNG, SVG (the same panels) or CSV (every
        sample) to ``client`` (the page that asked)."""
        from maniplab.gui.plot import image, table

        names, signals = self.plotted
        try:
            runs = [self.app.workspace.load_run(n) for n in names]
            units = self.app.configure.units
            content: str | bytes = (table(runs, names, signals, units) if fmt == "csv"
                                    else image(runs, names, signals, fmt, units))
            path = self.app.download(f"plot-{'-'.join(names)}"[:64], f".{fmt}", content, client)
        except (ManiplabError, OSError, ValueError) as exc:
            self.export_note(f"⚠ {exc}")
            return
        self.export_note(f"{fmt.upper()} written to exports/{path.name} and sent to the browser")


PANE_WIDTH = 860
"""Width of the plot pane, CSS px (the user may resize and move it)."""

PLOT_CONFIG = {"displaylogo": False, "scrollZoom": True, "responsive": True,
               "toImageButtonOptions": {"format": "png", "scale": 2}}
"""The plot's toolbar: zoom, pan, autoscale and its own PNG snapshot; the wheel zooms."""
