"""The Simulate tab: open-loop runs with inputs per joint, and closed-loop moves to a target.

An input is the command line's signal text (``step:0.5@0.1+sine:0.1,2``, see
:mod:`maniplab.sim.grammar`), typed or built term by term; the paper's three headline parameters
(payload mass, leakage, viscous friction) are direct controls. Each run is stored in the
workspace with its parameters (the run file holds its spec, inputs and overrides).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np

from maniplab.errors import ManiplabError
from maniplab.gui.text import Note, plain, warning
from maniplab.sim.grammar import parse_input

if TYPE_CHECKING:
    from maniplab.gui.app import Gui
    from maniplab.gui.units import Units
    from maniplab.sim.run import Run
    from maniplab.spec import ManipulatorSpec

KINDS = {  # kind -> labels of its first and second number ("" unused)
    "step": ("Amplitude [A | N | N·m]", ""),
    "impulse": ("Area [A·s | N·s | N·m·s]", "Width [s]"),
    "sine": ("Amplitude [A | N | N·m]", "Frequency [Hz]"),
    "ramp": ("Slope [A/s | N/s | N·m/s]", "Until [s]"),
}
ALL = "all joints"
UNUSED = "(unused)"
SYNTAX = ("Input syntax: `step:A@t0`, `sine:A,f@t0`, `ramp:slope,until@t0`, "
          "`impulse:area,width@t0`, terms joined by `+` (e.g. `step:0.5@0.1+sine:0.1,2`); "
          "blank: no input")
BIG = 1e6
"""Bound of the page's free numbers (amplitudes, times, payload kg, target m)."""
MAX_DURATION = 3600.0
"""Longest run or move the page asks for, s."""


def term(kind: str, first: float, second: float, t0: float) -> str:
    """One signal term in the input grammar, e.g. ``sine:0.1,2@0.5``."""
    args = f"{first:g}" if not KINDS[kind][1] or (kind != "sine" and second <= 0.0) \
        else f"{first:g},{second:g}"
    return f"{kind}:{args}" + (f"@{t0:g}" if t0 else "")


def inputs_of(texts: dict[str, str]) -> dict[str | int, Any]:
    """Joint -> signal from the texts typed per joint (blank: no input); raises the grammar's
    one-line error naming the joint."""
    inputs: dict[str | int, Any] = {}
    for joint, text in texts.items():
        if text.strip():
            name, signal = parse_input(f"{joint}={text.strip()}")
            inputs[name] = signal
    return inputs


def headline_overrides(spec: ManipulatorSpec, joint: str, payload: float, leakage: float | None,
                       viscous: float | None) -> dict[str, Any]:
    """Overrides for the paper's three parameters: the payload mass (kg), and the leakage
    (m³/(s·Pa)) and viscous friction (N·s/m or N·m·s/rad) of ``joint`` or of all joints (None:
    the spec's); only values that differ from the spec are given."""
    overrides: dict[str, Any] = {}
    if payload != spec.end_effector.mass:
        overrides["end_effector.mass"] = payload
    joints = spec.joints if joint == ALL else [spec.joint(joint)]
    for j in joints:
        if leakage is not None and getattr(j.actuator, "leakage", None) not in (None, leakage):
            overrides[f"joints.{j.name}.actuator.leakage"] = leakage
        if viscous is not None and j.friction.viscous != viscous:
            overrides[f"joints.{j.name}.friction.viscous"] = viscous
    return overrides


class SimulateTab:
    """The Simulate tab of ``app``."""

    def __init__(self, app: Gui) -> None:
        self.app = app
        gui = app.server.gui
        self.name = gui.add_text("Run name", "run", hint="stored as runs/NAME.npz ('-2', '-3'... "
                                 "added when taken)")
        with gui.add_folder("Inputs"):
            gui.add_markdown(SYNTAX)
            self.input_folder = gui.add_folder("Per joint (valve current A, or force/torque)")
            self.inputs: dict[str, Any] = {}
            self.input_error = gui.add_markdown("", visible=False)
            with gui.add_folder("Build a term", expand_by_default=False):
                self.term_joint = gui.add_dropdown("Joint", ["-"])
                self.kind = gui.add_dropdown("Signal", tuple(KINDS))
                self.first = gui.add_number(KINDS["step"][0], 0.5, min=-BIG, max=BIG)
                self.second = gui.add_number(UNUSED, 0.0, min=-BIG, max=BIG, disabled=True)
                self.kind.on_update(lambda _: self._label_numbers())
                self.t0 = gui.add_number("Start time t0 [s]", 0.1, min=0.0, max=BIG)
                gui.add_button("Add term").on_click(lambda _: self.add_term())
                gui.add_button("Clear joint").on_click(lambda _: self.clear_input())
        with gui.add_folder("Parameters"):
            self.payload = gui.add_number("Payload mass [kg]", 0.0, min=0.0, max=BIG)
            self.target_joint = gui.add_dropdown("Leakage and friction of", [ALL])
            self.leakage = gui.add_text("Leakage [m³/(s·Pa)]", "", hint="blank: the spec's")
            self.viscous = gui.add_text("Viscous friction [N·m·s/rad | N·s/m]", "",
                                        hint="blank: the spec's")
            self.start = gui.add_text("Start pose q", "", hint="comma-separated, "
                                      "one per joint; blank: all 0 (within the limits). Open "
                                      "loop starts there held against gravity; a move starts "
                                      "there too")
            self.duration = gui.add_number("Duration [s]", 2.0, min=0.001, max=MAX_DURATION)
            self.dt = gui.add_number("Time step [s]", 1e-3, min=1e-6, max=0.1, step=1e-4)
            self.record = gui.add_text(
                "Record every [s]", "", hint="the run's sample interval, a multiple of the time "
                "step (blank: every step, at most 1000 samples per second); a longer interval "
                "stores a smaller run file. Runs and moves")
        self.run_button = gui.add_button("Run", color="green")
        self.run_button.on_click(lambda _: self.run_open_loop())
        self.run_note = Note(gui)
        app.job_buttons.append(self.run_button)
        with gui.add_folder("Closed loop"):
            self.target = gui.add_vector3("Target x, y, z", (0.0, 0.0, 0.0), step=0.01,
                                          min=(-BIG,) * 3, max=(BIG,) * 3)
            self.move_duration = gui.add_number("Move duration [s]", 2.0, min=0.01,
                                                max=MAX_DURATION)
            self.mode = gui.add_dropdown("Controller", ("cascade", "pid", *app.controllers))
            self.fit = gui.add_dropdown(
                "Too fast for the valves", FITS, initial_value=FITS[0],
                hint="a move asked faster than the actuators allow: stretched to the shortest "
                     "duration that works (said and stored with the run), or refused")
            self.move_button = gui.add_button("Run move", color="green")
            self.move_button.on_click(lambda _: self.run_move())
            app.job_buttons.append(self.move_button)
            self.verdict = gui.add_markdown("")
        self.gizmo: Any = None
        self.target.on_update(lambda _: self._place_gizmo())
        self.units = app.configure.units
        app.on_spec(self.refresh)
        app.on_units(self.units_changed)
        self.refresh()

    def refresh(self) -> None:
        """Fit the tab to the current arm: one input per joint, parameters, target gizmo."""
        spec = self.app.spec
        names = [j.name for j in spec.joints]
        if list(self.inputs) != names:
            for handle in self.inputs.values():
                handle.remove()
            with self.input_folder:
                self.inputs = {n: self.app.server.gui.add_text(
                    _input_label(n, j), "", hint="e.g. step:0.5@0.1 or "
                    "sine:0.1,2@0.5+ramp:1,2; blank: no input") for n, j in zip(names, spec.joints)}
            self.term_joint.options = names
            self.target_joint.options = [ALL, *names]
        self.payload.value = spec.end_effector.mass
        self._label_units()
        self._reset_target()

    def _label_units(self) -> None:
        """The start pose's and the target's labels in the units shown."""
        kinds = {_pose_unit(j, self.units)[0] for j in self.app.spec.joints}
        self.start.label = f"Start pose q [{' | '.join(sorted(kinds))}]"
        self.target.label = f"Target x, y, z [{self.units.length}]"

    def units_changed(self) -> None:
        """Show the start pose and the target in the units chosen in Configure (the values typed
        stay the same pose and point)."""
        spec = self.app.spec
        try:
            start = self._start(spec)
        except ManiplabError:
            start = None  # a pose that does not parse is left as typed
        target = self._target()
        self.units = self.app.configure.units
        if start is not None:
            self.start.value = ", ".join(f"{x:.6g}" for x in np.asarray(start) / _pose_scales(
                spec, self.units))
        self._label_units()
        self.target.value = self._shown_point(target)

    def _label_numbers(self) -> None:
        first, second = KINDS[self.kind.value]
        self.first.label = first
        self.second.label = second or UNUSED
        self.second.disabled = not second

    def clear_input(self) -> None:
        """Empty the chosen joint's input."""
        self.inputs[self.term_joint.value].value = ""

    def add_term(self) -> None:
        """Append the term built to the chosen joint's input."""
        field = self.inputs[self.term_joint.value]
        new = term(self.kind.value, self.first.value, self.second.value, self.t0.value)
        field.value = f"{field.value.strip()}+{new}" if field.value.strip() else new

    # --- open loop ------------------------------------------------------------------------------

    def run_open_loop(self) -> None:
        """Simulate the arm under the inputs and parameters given, and store the run."""
        spec = self.app.spec
        try:
            inputs = inputs_of({n: h.value for n, h in self.inputs.items()})
            overrides = headline_overrides(spec, self.target_joint.value, self.payload.value,
                                           _number(self.leakage.value, "leakage"),
                                           _number(self.viscous.value, "viscous friction"))
            run_spec = spec.with_overrides(overrides) if overrides else spec
            name = self._free_name(self.name.value)
            start = self._start(spec)
            sample_dt = self._sample_dt()
        except ManiplabError as exc:
            self._fail(str(exc))
            return
        self._fail(None)
        duration, dt = float(self.duration.value), float(self.dt.value)
        initial: dict[str, Any] = {"dP": "gravity"} | ({"q": start} if start else {})

        def work() -> Run:
            from maniplab.sim.simulate import simulate

            return simulate(run_spec, inputs=inputs, duration=duration, dt=dt,
                            initial=initial, label=name, progress=False, sample_dt=sample_dt)

        self.app.jobs.start(f"simulating {spec.name}", work, lambda run: self._store(run, name),
                            self.run_note)

    def clear_messages(self) -> None:
        """Hide the tab's messages."""
        self.run_note.clear()
        self._fail(None)
        self.verdict.content = ""

    def _start(self, spec: ManipulatorSpec) -> list[float] | None:
        """The start pose typed (None: blank), one finite number per joint (ControlError)."""
        from maniplab.control.point_to_point import parse_numbers

        text = self.start.value.strip()
        if not text:
            return None
        typed = np.asarray(parse_numbers(text, "start pose", (spec.n,)), dtype=float)
        return [float(x) for x in typed * _pose_scales(spec, self.units)]

    def _sample_dt(self) -> float | None:
        """The recording interval typed, s (None: blank, the default)."""
        value = _number(self.record.value, "record every")
        if value is not None and not value > 0.0:
            raise ManiplabError(f"record every: {value:g} s is not a positive interval")
        return value

    def _free_name(self, name: str) -> str:
        """``name`` checked before a run: it, or the ``-2``... it would be stored under, is a
        valid name (raises WorkspaceError, so no finished run is thrown away for its name)."""
        self.app.workspace.free_name(name)
        return name

    def _store(self, run: Run, name: str) -> str:
        stored = self.app.workspace.save_run(run, name)
        self.app.runs_changed()
        return f"stored run '{stored}': {run.health.verdict}"

    def _fail(self, message: str | None) -> None:
        self.input_error.content = warning(message) if message else ""
        self.input_error.visible = bool(message)

    # --- closed loop ----------------------------------------------------------------------------

    def _reset_target(self) -> None:
        """Put the target at the end-effector of the arm Configure shows (at its home pose)."""
        arm = self.app.configure.arm3d
        if arm is not None:
            self.target.value = self._shown_point(arm.end_effector)
            self._place_gizmo()

    def _target(self) -> np.ndarray:
        """The target typed, m, shape (3,)."""
        return np.asarray(self.target.value, dtype=float) * self.units.scale("length")[1]

    def _shown_point(self, point: Any) -> tuple[float, float, float]:
        """A point (m) in the length unit shown, to the millimetre."""
        per = self.units.scale("length")[1]
        x, y, z = (round(float(c) / per, 3 if per == 1.0 else 0) for c in _rounded(point))
        return x, y, z

    def _place_gizmo(self) -> None:
        position = self._target()
        if self.gizmo is None:
            self.gizmo = self.app.server.scene.add_transform_controls(
                "/target", scale=0.6, disable_rotations=True, position=position,
                visible=self.app.tab == "Simulate")
            self.gizmo.on_update(lambda _: self._from_gizmo())
            self.app.server.scene.add_label("/target/name", text="move target",
                                            font_screen_scale=0.8, anchor="bottom-left")
        elif not np.allclose(self.gizmo.position, position):
            self.gizmo.position = position

    def _from_gizmo(self) -> None:
        self.target.value = self._shown_point(self.gizmo.position)

    def run_move(self) -> None:
        """Run the chosen controller (the cascade, the PID-only baseline, or one of yours) to the
        target and store the run, with the move in its metadata (``meta["move"]``: target, asked
        and actual duration, whether the planner stretched it, controller, verdict)."""
        from maniplab.control.move import run_move

        spec, target = self.app.spec, [float(x) for x in self._target()]
        duration, mode = float(self.move_duration.value), self.mode.value
        fit = FIT_MODES[self.fit.value]
        try:
            name = self._free_name(f"{self.name.value}-{mode}")
            start = self._start(spec)
            sample_dt = self._sample_dt()
        except ManiplabError as exc:
            self.verdict.content = warning(exc)
            return

        def done(result: Any) -> str:
            move = move_record(result, target, duration, mode, fit)
            self.verdict.content = "  \n".join(
                (warning if k == 0 and move["stretched"] else plain)(line)
                for k, line in enumerate(move_lines(move)))
            return self._store(dataclasses.replace(result.run, meta={**result.run.meta,
                                                                      "move": move}), name)

        def say(text: str) -> None:  # the job's start, end and failure, next to Run move
            if text.startswith("stored run"):
                self.verdict.content = f"{plain(text)}  \n{self.verdict.content}"
            elif text.endswith("..."):
                self.verdict.content = plain(text)
            else:
                self.verdict.content = warning(text)

        self.verdict.content = ""
        factory = self.app.controllers.get(mode)  # your own (gui --controller), else built-in
        self.app.jobs.start(f"{mode} move of {spec.name}",
                            lambda: run_move(spec, target, start=start, duration=duration,
                                             mode="cascade" if factory else mode,
                                             controller=factory, fit_mode=fit,
                                             sample_dt=sample_dt), done, say)


FITS = ("stretch it", "refuse it")
FIT_MODES = {"stretch it": "stretch", "refuse it": "refuse"}


def move_record(result: Any, target: list[float], asked: float, mode: str, fit: str
                ) -> dict[str, Any]:
    """What a closed-loop move was asked and what it did, JSON-friendly (a run's
    ``meta["move"]``): target (m), asked and actual duration (s), stretched, why, the controller,
    the fit mode, the errors (mm) and the verdict's findings."""
    plan, metrics = result.plan, result.metrics
    why = plan.note()
    if why is not None:  # the command line's advice, said in the page's words
        why = why.split(" (--fit")[0]
    return {
        "target": [float(x) for x in target],
        "asked_duration": float(asked),
        "duration": float(plan.move.duration),
        "stretched": bool(plan.stretched),
        "why": why,
        "controller": mode,
        "fit": fit,
        "final_error_mm": float(metrics.final_error_mm),
        "rms_error_mm": float(metrics.rms_error_mm),
        "missed": result.missed(),
        "verdict": result.health.verdict,
        "findings": list(dict.fromkeys(result.health.lines())),
    }


def move_lines(move: dict[str, Any]) -> list[str]:
    """The move's verdict as lines, each sentence once: the stretch first (asked and actual
    duration), then the health verdict with its findings, then what was missed (when its cause
    is not a finding said already)."""
    lines = []
    if move["stretched"]:
        lines.append(f"move stretched: asked {move['asked_duration']:g} s, ran "
                     f"{move['duration']:.3g} s" + (f" ({move['why'].split(': ', 1)[1]})"
                                                   if move.get("why") and ": " in move["why"]
                                                   else ""))
    else:
        lines.append(f"move ran in the {move['asked_duration']:g} s asked")
    findings = move["findings"]
    verdict = str(move["verdict"])
    first = findings[0] if findings else ""
    if first.startswith("warning: ") and verdict == "warnings":  # said once: 'health warnings'
        first = first.removeprefix("warning: ")
    lines.append(f"health {verdict}" + (f": {first}" if findings else ""))
    lines.extend(findings[1:])
    missed = move["missed"]
    if missed is None:
        lines.append(f"tolerances met (final error {move['final_error_mm']:.3g} mm, RMS "
                     f"{move['rms_error_mm']:.3g} mm)")
    else:
        said = [f.split(": ", 1)[-1] for f in findings]
        cause = next((s for s in said if s and s in missed), None)
        lines.append(missed.replace(": " + cause, "") if cause else missed)
    return lines


def _input_label(name: str, joint: Any) -> str:
    """A joint's input field's label: its name and its command's unit in brackets (the name
    alone when the command has no unit)."""
    unit = _input_unit(joint)
    return f"{name} [{unit}]" if unit else name


def _input_unit(joint: Any) -> str:
    """The unit of a joint's input, as its actuator declares it (a valve's command unit, a
    force source's N or N·m by the joint's kind; none for a passive joint or a plugin that
    declares none)."""
    from maniplab.spec import model_of

    try:
        unit = str(model_of(joint).command_unit)
    except ManiplabError:  # a stored run's plugin that is not loaded
        return ""
    if "|" in unit:  # "N | N·m": a force on a prismatic joint, a torque on a rotational one
        force, torque = (part.strip() for part in unit.split("|", 1))
        return torque if joint.type.value == "R" else force
    return unit


def _pose_unit(joint: Any, units: Units) -> tuple[str, float]:
    """(unit shown, SI per unit) of a joint's position: deg or rad, m or mm."""
    unit = units.of("position", joint.type.value == "R")
    assert unit is not None  # a position is a number
    return unit


def _pose_scales(spec: ManipulatorSpec, units: Units) -> np.ndarray:
    """SI per unit shown of each joint's position, shape (n,)."""
    return np.array([_pose_unit(j, units)[1] for j in spec.joints])


def _number(text: str, what: str) -> float | None:
    if not text.strip():
        return None
    try:
        return float(text)
    except ValueError:
        raise ManiplabError(f"{what}: '{text}' is not a number") from None


def _rounded(position: Any) -> tuple[float, float, float]:
    """A position to the millimetre, m."""
    x, y, z = (round(float(c), 3) for c in position)
    return x, y, z
