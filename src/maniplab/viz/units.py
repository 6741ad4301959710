"""The units signals are shown in: the same in figures and in the plot strip under a video.

Runs store SI values (:data:`maniplab.sim.run.UNITS`); a hydraulic arm's pressures read better in
MPa, its flows in L/min, its forces in kN.
"""

from __future__ import annotations

DISPLAY: dict[str, tuple[str, float, str, str]] = {
    "q": ("position", 1.0, "rad", "m"),
    "qd": ("velocity", 1.0, "rad/s", "m/s"),
    "qdd": ("acceleration", 1.0, "rad/s²", "m/s²"),
    "tau_act": ("actuator force", 1e-3, "kN·m", "kN"),
    "tau_fric": ("friction force", 1e-3, "kN·m", "kN"),
    "tau_limit": ("limit force", 1e-3, "kN·m", "kN"),
    "dP": ("ΔP", 1e-6, "MPa", "MPa"),
    "pA": ("cap-side pressure", 1e-6, "MPa", "MPa"),
    "pB": ("rod-side pressure", 1e-6, "MPa", "MPa"),
    "pL_d": ("desired load pressure", 1e-6, "MPa", "MPa"),
    "stroke": ("piston travel", 1e3, "mm", "mm"),
    "cylinder_force": ("cylinder force", 1e-3, "kN", "kN"),
    "spool": ("spool opening", 1.0, "", ""),
    "hold_a": ("cap-side holding valve opening", 1.0, "", ""),
    "hold_b": ("rod-side holding valve opening", 1.0, "", ""),
    "Q": ("oil flow", 6e4, "L/min", "L/min"),
    "iv": ("valve current", 1.0, "A", "A"),
    "ctrl": ("command", 1.0, "", ""),
    "mode": ("friction mode", 1.0, "", ""),
    "ee_pos": ("end-effector position", 1.0, "m", "m"),
}
"""signal -> (what it is, scale from SI to the shown unit, unit on a rotational joint, unit on a
prismatic joint)."""


def display(signal: str, prismatic: bool | None) -> tuple[str, float, str]:
    """(what, scale, unit) to show ``signal`` of a joint; ``prismatic`` None: joints of both kinds
    (the unit reads "rad | m" where they differ). Unknown signals are shown as stored."""
    what, scale, rotational, linear = DISPLAY.get(signal, (signal, 1.0, "", ""))
    if prismatic is None:
        unit = rotational if rotational == linear else f"{rotational} | {linear}"
    else:
        unit = linear if prismatic else rotational
    return what, scale, unit
