"""The Configure tab: the arm as a table of joints in the paper's vocabulary, edited field by field.

Every field is a YAML value set through :meth:`ManipulatorSpec.with_overrides`, so every rule of a
spec file holds (a body's COG and inertia left at their defaults follow its length and mass). A bad
value shows the spec's one-line error under the field and changes nothing: the arm keeps its last
valid state and the 3D view stays whole.
"""

from __future__ import annotations

import html
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from maniplab.builtin import builtin_spec, builtin_specs
from maniplab.errors import ManiplabError, SpecError
from maniplab.gui.arm3d import Arm3D, looks
from maniplab.gui.replay import stage
from maniplab.gui.text import Note, warning
from maniplab.gui.units import CHOICES, ENUMS, FIELDS, Units, describe, number, shown, si
from maniplab.spec import ManipulatorSpec
from maniplab.spec.yaml_io import dump_yaml, parse_yaml
from maniplab.viz.arm import ArmView

if TYPE_CHECKING:
    from maniplab.gui.app import Gui

ARM_FIELDS = (
    ("name", "the arm's name"),  # shown as "arm name"
    ("gravity", "m/s², [x, y, z]"),
    ("end_effector.mass", "payload, kg"),
    ("end_effector.offset", "payload centre from the last joint, m"),
)
JOINT_FIELDS = (
    ("name", "joint name"),
    ("type", "R (revolute) or Tr (translational)"),
    ("axis", "x, y or z of the previous body's frame"),
    ("limits", "[lower, upper], rad or m; blank: none"),
    ("body.length", "m"),
    ("body.direction", "unit vector [x, y, z]"),
    ("body.mass", "kg"),
    ("body.com", "COG, m, [x, y, z]; blank: the middle of the body"),
    ("body.inertia", "kg·m² about the COG, [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]; blank: a rod"),
)
_MODELS = ("python", "c", "latex", "markdown")
_SUFFIX = {"python": ".py", "c": ".c", "latex": ".tex", "markdown": ".md"}


def text_of(value: Any) -> str:
    """A field's value as the page shows it: YAML in flow style (blank for None)."""
    if value is None:
        return ""
    return dump_yaml(value).strip().removesuffix("...").strip()


def value_of(text: str) -> Any:
    """A field's text as a value (YAML; blank is None)."""
    return parse_yaml(text)[0] if text.strip() else None


def lookup(data: dict[str, Any], path: str) -> Any:
    """The value at dotted ``path`` in nested dicts (None where a section is absent)."""
    node: Any = data
    for part in path.split("."):
        node = node.get(part) if isinstance(node, dict) else None
    return node


class Field:
    """An input with its error line under it: a text (YAML, in the unit its label names) or,
    for an enumeration, a dropdown."""

    def __init__(self, gui: Any, path: str, hint: str, value: Any, apply: Any,
                 label: str | None = None, unit: tuple[str, float] | None = None,
                 options: tuple[str, ...] | None = None) -> None:
        self.path, self.unit = path, unit
        self.options: tuple[str, ...] | None
        text = text_of(shown(value, unit))
        if options is not None:
            self.options = options if text in options else (*options, text)
            self.input = gui.add_dropdown(label or path, self.options, initial_value=text,
                                          hint=hint)
        else:
            self.options = None
            self.input = gui.add_text(label or path, text, hint=hint)
        self.error = gui.add_markdown("", visible=False)
        self.quiet = False
        self.input.on_update(lambda _: None if self.quiet else apply(self))

    def value(self) -> Any:
        """The value typed, in SI (raises SpecError for text that is not YAML)."""
        return si(value_of(self.input.value), self.unit)

    def show_value(self, value: Any) -> None:
        """Show the SI ``value`` (in the field's unit) without applying it."""
        self.show(text_of(shown(value, self.unit)))

    def show(self, text: str) -> None:
        """Set the text without applying it."""
        self.quiet = True
        try:
            if self.options is not None and text not in self.options:
                self.options = (*self.options, text)
                self.input.options = self.options
            self.input.value = text
        finally:
            self.quiet = False

    def fail(self, message: str | None) -> None:
        """Show ``message`` under the field (None: hide the line)."""
        self.error.content = warning(message) if message else ""
        self.error.visible = bool(message)

    def remove(self) -> None:
        self.input.remove()
        self.error.remove()


class ConfigureTab:
    """The Configure tab of ``app``."""

    def __init__(self, app: Gui) -> None:
        self.app = app
        self._quiet = False  # True while the page's widgets are set from the spec
        gui = app.server.gui
        self.builtin = gui.add_dropdown("Built-in arm", builtin_specs(),
                                        initial_value=_initial(app.spec))
        gui.add_button("Start from this built-in").on_click(lambda _: self.load_builtin())
        self.builtin_note = Note(gui)
        self.table = gui.add_html("")
        self.key = gui.add_html("")
        with gui.add_folder("Units", expand_by_default=False):
            self.unit_choice = {quantity: gui.add_dropdown(
                f"{quantity.capitalize()} in", tuple(u for u, _ in options))
                for quantity, options in CHOICES.items()}
            for dropdown in self.unit_choice.values():
                dropdown.on_update(lambda _: self._units_changed())
        self.units = Units()
        with gui.add_folder("Arm"):
            self.arm_fields = []
            for path, hint in ARM_FIELDS:
                label, unit = describe(path, self.units)
                self.arm_fields.append(Field(gui, path, hint, None, self._apply_arm,
                                             label="Arm name" if path == "name" else label,
                                             unit=unit))
        with gui.add_folder("Joint"):
            self.joint = gui.add_dropdown("Joint", [j.name for j in app.spec.joints])
            self.joint.on_update(lambda _: None if self._quiet else self._rebuild_fields())
            self.body_on = gui.add_checkbox("Body mass on", True,
                                            hint="off: the body weighs nothing (its mass is "
                                                 "kept and comes back when on)")
            self.body_on.on_update(lambda _: self._toggle_body())
            with gui.add_folder("Structure", expand_by_default=False):
                for label, action in (("Add joint after", self.add_joint),
                                      ("Remove joint", self.remove_joint),
                                      ("Move up", lambda: self.move_joint(-1)),
                                      ("Move down", lambda: self.move_joint(1))):
                    gui.add_button(label).on_click(_call(action))
                self.structure_note = Note(gui)
            self.fields_folder = gui.add_folder("Fields")
        self.joint_fields: list[Field] = []
        self._masses: dict[str, float] = {}  # body masses switched off, kg
        self._select: str | None = None  # the joint to select after the next change
        # the field whose edit is being applied: its text is left as the page holds it, since a
        # newer edit may already be there, waiting for its callback (writing back the value
        # just applied would overwrite it and lose the last edit)
        self._typed: Field | None = None
        with gui.add_folder("Save and export", expand_by_default=False):
            self.file_name = gui.add_text("Spec name", _safe(app.spec.name),
                                          hint="saved as specs/NAME.yaml in the workspace")
            gui.add_button("Save spec").on_click(lambda _: self.save())
            gui.add_button("Download MJCF").on_click(lambda event: self.download_mjcf(event.client))
            self.model_format = gui.add_dropdown("Analytic model", _MODELS)
            model_button = gui.add_button("Download analytic model")
            model_button.on_click(lambda event: self.download_model(event.client))
            app.job_buttons.append(model_button)
            self.save_note = Note(gui)
        self.arm3d: Arm3D | None = None
        self._looks = b""  # what the arm drawn looks like (arm3d.looks)
        app.on_spec(self.refresh)
        self.refresh()

    # --- showing the arm ------------------------------------------------------------------------

    def refresh(self) -> None:
        """Show the current arm: table, fields, 3D view. The fields are rebuilt only when the
        selected joint's set of fields changed, so a field being typed in keeps its focus."""
        spec = self.app.spec
        self.table.content = joint_table(spec, self.units)
        data = spec.to_dict()
        for field, (path, _) in zip(self.arm_fields, ARM_FIELDS):
            if field is not self._typed:
                field.show_value(lookup(data, path))
        names = [j.name for j in spec.joints]
        wanted = self._select or self.joint.value
        self._select = None
        self._quiet = True
        try:
            if list(self.joint.options) != names:
                self.joint.options = names
            self.joint.value = wanted if wanted in names else names[0]
        finally:
            self._quiet = False
        if [f.path for f in self.joint_fields] != [p for p, _ in self._paths()]:
            self._rebuild_fields()
        else:
            self._sync_values()
        self._draw()

    def _paths(self) -> list[tuple[str, str]]:
        """The fields of the selected joint: path, hint."""
        spec = self.app.spec
        joint = spec.to_dict()["joints"][spec.joint_index(self.joint.value)]
        return [*JOINT_FIELDS, *_leaves(joint, "actuator"), *_leaves(joint, "friction")]

    def _draw(self) -> None:
        """Show the arm in 3D: redrawn when it looks different, else only posed again (an edit
        of a mass or a valve sends the page nothing to rebuild)."""
        spec = self.app.spec
        server = self.app.server
        view = ArmView(spec)
        drawn = looks(view)
        if self.arm3d is not None and drawn == self._looks:
            self.arm3d.view = view
            self.arm3d.pose(home(spec))
            return
        if self.arm3d is not None:
            self.arm3d.remove()
        self._looks = drawn
        self.arm3d = Arm3D(server.scene, "/arm", spec, labels=True, view=view)
        self.arm3d.pose(home(spec))
        cell = stage(server, [spec], self.arm3d.bounds())
        self.key.content = scene_key(spec, cell)

    def _rebuild_fields(self) -> None:
        for field in self.joint_fields:
            field.remove()
        spec = self.app.spec
        joint = spec.to_dict()["joints"][spec.joint_index(self.joint.value)]
        revolute = joint.get("type", "R") == "R"
        self.joint_fields = []
        with self.fields_folder:
            for path, hint in self._paths():
                label, unit = describe(path, self.units, revolute)
                self.joint_fields.append(Field(
                    self.app.server.gui, path, hint, lookup(joint, path), self._apply_joint,
                    label="Joint name" if path == "name" else label, unit=unit,
                    options=ENUMS.get(path)))
        self.body_on.value = self.joint.value not in self._masses

    def _units_changed(self) -> None:
        """Show every field and the table in the units chosen."""
        self.units = Units(**{q: str(d.value) for q, d in self.unit_choice.items()})
        self.app.units_changed()
        spec = self.app.spec
        self.table.content = joint_table(spec, self.units)
        data = spec.to_dict()
        for field, (path, _) in zip(self.arm_fields, ARM_FIELDS):
            field.unit = describe(path, self.units)[1]
            field.input.label = "Arm name" if path == "name" else describe(path, self.units)[0]
            field.show_value(lookup(data, path))
        self._rebuild_fields()

    # --- editing --------------------------------------------------------------------------------

    def _apply_arm(self, field: Field) -> None:
        self._apply(field, field.path)

    def _apply_joint(self, field: Field) -> None:
        self._apply(field, f"joints.{self.joint.value}.{field.path}")

    def _apply(self, field: Field, path: str) -> None:
        try:
            value = field.value()
            spec = self.app.spec.with_overrides({path: value})
        except ManiplabError as exc:
            field.fail(str(exc))
            return
        field.fail(None)
        if path == f"joints.{self.joint.value}.name":
            self._select = str(value)
        self._typed = field
        try:
            self.app.set_spec(spec)
        finally:
            self._typed = None

    def _sync_values(self) -> None:
        """Show the values that followed an edit (a COG follows its body's length)."""
        data = self.app.spec.to_dict()
        joint = data["joints"][self.app.spec.joint_index(self.joint.value)]
        for field in self.joint_fields:
            if field is not self._typed:
                field.show_value(lookup(joint, field.path))

    def _toggle_body(self) -> None:
        name = self.joint.value
        spec = self.app.spec
        joint = spec.joint(name)
        if self.body_on.value and name in self._masses:
            self.app.set_spec(spec.with_overrides(
                {f"joints.{name}.body.mass": self._masses.pop(name)}))
        elif not self.body_on.value and name not in self._masses and joint.body is not None:
            self._masses[name] = joint.body.mass
            self.app.set_spec(spec.with_overrides({f"joints.{name}.body.mass": 0.0}))

    def _edit_joints(self, edit: Any) -> None:
        """Apply ``edit(joints list, index of the selected joint) -> index to select``."""
        data = self.app.spec.to_dict()
        index = self.app.spec.joint_index(self.joint.value)
        try:
            selected = edit(data["joints"], index)
            spec = ManipulatorSpec.from_dict(data, source=self.app.spec.source)
        except ManiplabError as exc:
            self.structure_note(f"⚠ {exc}")
            return
        self.structure_note.clear()
        self._select = spec.joints[selected].name
        self.app.set_spec(spec)

    def add_joint(self) -> None:
        """Insert a copy of the selected joint after it, under a new name."""
        def edit(joints: list[dict[str, Any]], k: int) -> int:
            taken = {j["name"] for j in joints}
            copy = {**joints[k], "name": _fresh(joints[k]["name"], taken)}
            joints.insert(k + 1, copy)
            return k + 1
        self._edit_joints(edit)

    def remove_joint(self) -> None:
        """Remove the selected joint (an arm keeps at least one)."""
        def edit(joints: list[dict[str, Any]], k: int) -> int:
            if len(joints) == 1:
                raise SpecError("an arm needs at least one joint", joint=joints[k]["name"])
            del joints[k]
            return min(k, len(joints) - 1)
        self._edit_joints(edit)

    def move_joint(self, by: int) -> None:
        """Move the selected joint ``by`` places along the chain."""
        def edit(joints: list[dict[str, Any]], k: int) -> int:
            to = min(max(k + by, 0), len(joints) - 1)
            joints.insert(to, joints.pop(k))
            return to
        self._edit_joints(edit)

    def load_builtin(self) -> None:
        """Replace the arm by the built-in chosen."""
        self._masses.clear()
        spec = builtin_spec(self.builtin.value)
        self.file_name.value = _safe(spec.name)
        self.app.set_spec(spec)
        self.builtin_note(f"loaded the built-in {spec.name}")

    # --- saving ---------------------------------------------------------------------------------

    def save(self) -> None:
        """Write the spec into the workspace."""
        try:
            path = self.app.workspace.save_spec(self.app.spec, self.file_name.value)
        except (ManiplabError, OSError) as exc:
            self.save_note(f"⚠ {exc}")
            return
        self.save_note(f"saved {path}")

    def download_mjcf(self, client: Any = None) -> None:
        """Send the arm's MJCF to ``client`` (the page that asked)."""
        from maniplab.mjcf_gen import to_mjcf

        try:
            path = self.app.download(_safe(self.app.spec.name), ".xml", to_mjcf(self.app.spec),
                                     client)
        except (ManiplabError, OSError) as exc:
            self.save_note(f"⚠ {exc}")
            return
        self.save_note(f"MJCF written to {path} and sent to the browser")

    def download_model(self, client: Any = None) -> None:
        """Derive the analytic model in the chosen format (a job: it can take seconds) and send it
        to ``client`` (the page that asked)."""
        from maniplab.model.export import export_model

        spec, fmt = self.app.spec, self.model_format.value

        def done(text: str) -> str:
            path = self.app.download(f"{_safe(spec.name, 58)}_model", _SUFFIX[fmt], text, client)
            return f"analytic model written to {path} and sent to the browser"

        self.app.jobs.start(f"deriving the {fmt} model", lambda: export_model(spec, fmt, []),
                            done, self.save_note)

    def clear_messages(self) -> None:
        """Hide the tab's messages (the fields' errors stay with their fields)."""
        for note in (self.builtin_note, self.structure_note, self.save_note):
            note.clear()


def _call(action: Callable[[], None]) -> Callable[[Any], None]:
    """A click handler calling ``action()``."""
    return lambda _: action()


def home(spec: ManipulatorSpec) -> np.ndarray:
    """The pose shown while configuring: every joint at 0, or at its nearest limit."""
    q = np.zeros(spec.n)
    for j, joint in enumerate(spec.joints):
        if joint.limits is not None:
            q[j] = min(max(0.0, joint.limits[0]), joint.limits[1])
    return q


def joint_table(spec: ManipulatorSpec, units: Units | None = None) -> str:
    """The joints as an HTML table in the paper's vocabulary, one column per joint and one row
    per quantity with its unit (the limits in the angle unit for a revolute joint, the length
    unit for a prismatic one)."""
    units = units or Units()
    length, metres = units.scale("length")
    angle, radians = units.scale("angle")

    def limits(joint: Any) -> str:
        if not joint.limits:
            return "none"
        revolute = joint.type.value == "R"
        per = radians if revolute else metres
        return f"{_v([x / per for x in joint.limits])} {angle if revolute else length}"

    rows: list[tuple[str, Any]] = [
        ("type", lambda j: "R" if j.type.value == "R" else "Tr"),
        ("axis", lambda j: j.axis.value),
        (f"limits [{angle} | {length}]", limits),
        (f"body length [{length}]", lambda j: number(j.body.length / metres) if j.body else "–"),
        ("body direction", lambda j: _v(j.body.direction) if j.body else "–"),
        ("body mass [kg]", lambda j: number(j.body.mass) if j.body else "0"),
        (f"COG [{length}]", lambda j: _v([x / metres for x in j.body.com])
         if j.body and j.body.com else "–"),
        ("Ixx, Iyy, Izz [kg·m²]", lambda j: _v(j.body.inertia[:3])
         if j.body and j.body.inertia else "–"),
        ("actuator", _actuator),
        ("friction Fc / Fs [N·m | N]", lambda j: "/".join(
            number(x) for x in (j.friction.coulomb, j.friction.static))),
        ("viscous Fv [N·m·s/rad | N·s/m]", lambda j: number(j.friction.viscous)),
    ]
    if any(j.rod_friction is not None for j in spec.joints):
        rows.append(("rod friction Fc / Fs / Fv [N, N·s/m]", _rod))
    style = ("<style>.ml-joints{border-collapse:collapse;font-size:11px}"
             ".ml-joints td,.ml-joints th{border:1px solid #ccc;padding:1px 4px;font-size:10px}"
             ".ml-joints th{text-align:left;font-weight:600}</style>")
    header = "<tr><th>joint</th>" + "".join(f"<th>{html.escape(j.name)}</th>"
                                            for j in spec.joints) + "</tr>"
    body = "".join("<tr><th>" + html.escape(name) + "</th>" + "".join(
        f"<td>{html.escape(str(cell(j)))}</td>" for j in spec.joints) + "</tr>"
        for name, cell in rows)
    payload = (f"<p style='font-size:11px'>payload {number(spec.end_effector.mass)} kg, gravity "
               f"{_v(spec.gravity)} m/s²</p>")
    return (f"{style}<div style='overflow-x:auto'><table class='ml-joints' id='ml-joints'>"
            f"{header}{body}</table></div>{payload}")


def scene_key(spec: ManipulatorSpec, cell: float) -> str:
    """What the 3D view's colours and marks mean, as HTML: the links' colours by joint, the
    cylinders', the joint states', the axes and the grid's scale."""
    from maniplab.viz import palette
    from maniplab.viz.cylinders import BARREL, ROD

    def swatch(rgba: Any, text: str) -> str:
        r, g, b = palette.to_uint8(tuple(float(c) for c in rgba[:4]))  # type: ignore[arg-type]
        return f"<span style='color:rgb({r},{g},{b})'>■</span> {html.escape(text)}"

    links = [swatch(palette.link_colour(j), joint.name) for j, joint in enumerate(spec.joints)
             if joint.body is not None]
    marks = [swatch(BARREL, "cylinder barrel"), swatch(ROD, "rod"),
             swatch(palette.STICK, "joint sticking"), swatch(palette.LIMIT, "at a limit")]
    return ("<div id='ml-key' style='font-size:11px;line-height:1.5'>3D: links "
            + " ".join(links) + "; " + " ".join(marks)
            + f"; axes at the origin x red, y green, z blue; grid cells {number(cell)} m</div>")


def _rod(joint: Any) -> str:
    rod = joint.rod_friction
    return "–" if rod is None else "/".join(number(x) for x in (rod.coulomb, rod.static,
                                                                rod.viscous))


def _actuator(joint: Any) -> str:
    kind = getattr(joint.actuator, "type", None) or type(joint.actuator).__name__
    return str(getattr(kind, "value", kind))


def _g(x: float) -> str:
    return number(x)


def _v(values: Any) -> str:
    return "[" + ", ".join(_g(float(x)) for x in values) + "]"


def _leaves(joint: dict[str, Any], section: str) -> list[tuple[str, str]]:
    """The fields of a section, its nested sections (a cylinder, its pins, a valve) opened."""
    out = []

    def walk(node: dict[str, Any], prefix: str) -> None:
        for key, value in node.items():
            path = f"{prefix}.{key}"
            if isinstance(value, dict) and path not in FIELDS:
                walk(value, path)
            else:
                out.append((path, f"{section} parameter ({path}; YAML, in the unit of the label)"))
    walk(joint.get(section) or {}, section)
    return out


def _fresh(name: str, taken: set[str]) -> str:
    return next(f"{name}_{k}" for k in range(2, len(taken) + 3) if f"{name}_{k}" not in taken)


def _safe(name: str, length: int = 64) -> str:
    """``name`` as a workspace file name of at most ``length`` characters (ASCII letters and
    digits, ``-`` and ``_``; every other character becomes ``_``)."""
    cleaned = "".join(c if (c.isascii() and c.isalnum()) or c in "-_" else "_"
                      for c in name)[:length]
    return cleaned or "arm"


def _initial(spec: ManipulatorSpec) -> str:
    names = builtin_specs()
    return spec.name if spec.name in names else names[0]
