"""Colours of the rendered scene and of the 2-D annotations (RGBA, 0..1).

Links get distinct colours so a viewer can tell them apart; a joint's cylinder (or rail) is dark
grey while it slips, blue while stiction holds it and red while it sits at a limit. The blue and red
are used for nothing else, so the state of a joint reads at a glance (and a test can find them).
Runs compared in one video each get a colour for their ghost, caption, curve and path.
"""

from __future__ import annotations

from maniplab.friction.modes import FrictionMode

RGBA = tuple[float, float, float, float]

LINKS: tuple[RGBA, ...] = (
    (0.95, 0.66, 0.10, 1.0),  # hydraulic-machine yellow
    (0.25, 0.72, 0.42, 1.0),  # green
    (0.86, 0.42, 0.70, 1.0),  # pink
    (0.78, 0.62, 0.44, 1.0),  # sand
    (0.62, 0.68, 0.22, 1.0),  # olive
    (0.92, 0.86, 0.75, 1.0),  # ivory
)
"""Colour of link i is ``LINKS[i % len(LINKS)]``; no blue or red, which mark joint states."""

JOINT_STATES: dict[int, RGBA | None] = {
    FrictionMode.SLIP: None,  # the model's own material (dark grey cylinders, grey rails)
    FrictionMode.STICK: (0.10, 0.35, 1.00, 1.0),
    FrictionMode.AT_LOWER: (0.92, 0.10, 0.08, 1.0),
    FrictionMode.AT_UPPER: (0.92, 0.10, 0.08, 1.0),
}
"""Colour of a joint's geom per mode; None keeps the model's colour. The keys are FrictionMode
values, so the integers a run's "mode" signal stores look them up directly."""

STICK = JOINT_STATES[FrictionMode.STICK]
LIMIT = JOINT_STATES[FrictionMode.AT_LOWER]

PATH: RGBA = (1.0, 1.0, 1.0, 0.9)
"""End-effector path of a single run."""

RUNS: tuple[RGBA, ...] = (
    (0.95, 0.66, 0.10, 1.0),  # the reference run: the links' yellow
    (0.20, 0.85, 0.80, 1.0),  # teal
    (0.90, 0.35, 0.85, 1.0),  # magenta
    (0.55, 0.90, 0.30, 1.0),  # lime
    (0.95, 0.95, 0.95, 1.0),  # white
    (0.70, 0.50, 0.95, 1.0),  # lilac
)
"""Colour of run k in a comparison is ``RUNS[k % len(RUNS)]``."""

GHOST_ALPHA = 0.35
"""Opacity of the variants drawn as ghosts in an overlay."""

TEXT: RGBA = (0.96, 0.96, 0.96, 1.0)
PANEL: RGBA = (0.08, 0.09, 0.11, 0.62)
"""Text and the translucent panel behind it."""

BACKGROUND: RGBA = (0.11, 0.12, 0.14, 1.0)
"""Caption bands, plot strip and the unused cells of a grid."""


def link_colour(index: int) -> RGBA:
    """Colour of the link of joint ``index`` (0-based)."""
    return LINKS[index % len(LINKS)]


def run_colour(index: int) -> RGBA:
    """Colour of run ``index`` (0-based) in a comparison."""
    return RUNS[index % len(RUNS)]


def to_uint8(colour: RGBA) -> tuple[int, int, int]:
    """RGB of ``colour`` as 0..255 integers."""
    r, g, b = (round(255 * c) for c in colour[:3])
    return r, g, b
