"""Plain-text summary of a spec: one row per joint (what ``maniplab info`` prints)."""

from __future__ import annotations

from maniplab.spec import Joint, ManipulatorSpec, model_of
from maniplab.spec.arm import Supply

_HEADER = ("joint", "type", "axis", "limits", "body length", "direction", "mass [kg]",
           "actuator", "friction")


def spec_table(spec: ManipulatorSpec) -> str:
    """A table of joints, bodies, masses, actuators and limits, followed by totals."""
    rows = [_HEADER] + [_row(joint) for joint in spec.joints]
    widths = [max(len(row[i]) for row in rows) for i in range(len(_HEADER))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip() for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    ee = spec.end_effector
    total = sum(j.body.mass for j in spec.joints if j.body) + ee.mass
    details = [line for joint in spec.joints for line in model_of(joint).details()]
    if details:
        lines += ["", *details]
    if spec.supply is not None:
        sharing = ", ".join(j.name for j in spec.joints
                            if getattr(j.actuator, "cylinder", None) is not None)
        lines += ["", _pump_line(spec.supply, sharing)]
    lines += [
        "",
        f"end-effector: {ee.mass:g} kg at offset {_vec(ee.offset)} m"
        + (f", COG {_vec(ee.com)} m from it" if any(ee.com) else "")
        + (f", inertia {_vec(ee.inertia)} kg·m²" if any(ee.inertia) else ""),
        f"gravity: {_vec(spec.gravity)} m/s²    total moving mass: {total:g} kg",
    ]
    return f"{spec.name}: {spec.n} joints" + (f" ({spec.source})" if spec.source else "") + \
        "\n\n" + "\n".join(lines)


def _row(joint: Joint) -> tuple[str, ...]:
    unit = "m" if joint.prismatic else "rad"
    limits = f"[{joint.limits[0]:g}, {joint.limits[1]:g}] {unit}" if joint.limits else "-"
    body = joint.body
    return (
        joint.name,
        "P" if joint.prismatic else "R",
        joint.axis.value,
        limits,
        f"{body.length:g} m" if body else "-",
        _vec(body.direction) if body else "-",
        f"{body.mass:g}" if body else "-",
        model_of(joint).describe(),
        joint.friction.model.value + (" + rod" if joint.rod_friction is not None else ""),
    )


def _vec(values: tuple[float, ...]) -> str:
    return "[" + ", ".join(f"{v:g}" for v in values) + "]"


def _pump_line(supply: Supply, sharing: str) -> str:
    """The shared pump in one line: its kind, pressure, flow and the joints on it."""
    pressure = f"{supply.pressure / 1e6:g} MPa"
    if supply.ls_margin is not None:
        kind = f"load-sensing, margin {supply.ls_margin / 1e5:.4g} bar, cut-off {pressure}"
    elif supply.displacement == "fixed":
        kind = f"fixed displacement, relief at {pressure}"
    else:
        kind = pressure
    if supply.response is not None:
        kind += f", response {supply.response * 1e3:g} ms"
    return f"pump: {kind}, {supply.max_flow * 6e4:.4g} L/min, shared by {sharing}"
