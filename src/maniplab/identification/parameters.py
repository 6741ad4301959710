"""The parameters a fit adjusts: dotted spec paths (as ``--set``), with bounds.

``joints.q2.friction.coulomb`` fits from the spec's value within [0, ∞); ``end_effector.mass[0:8000]``
within the bounds given. Physical quantities stay positive: the default lower bound is 0. The fit
works on each value divided by its start, so parameters of any unit are searched alike; a positive
one (a start above 0 and a lower bound of at least 0: a flow, a friction, a leakage, a mass) on
the logarithm of that ratio (:attr:`Parameter.log_scale`), so that a start ten times too large
is as near as one ten times too small, and the value stays above :data:`FLOOR` of its start.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Iterable

from maniplab.errors import SpecError
from maniplab.sim.params import flatten_spec
from maniplab.spec import ManipulatorSpec

FLOOR = 1e-9
"""The smallest value a positive parameter is searched down to, over its start: its lower bound 0
is -∞ on the log scale."""

_BOUNDS = re.compile(r"^(?P<path>[^\[\]]+?)\s*(\[(?P<lo>[^:\]]*):(?P<hi>[^\]]*)\])?$")


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One fitted parameter.

    Attributes:
        path: the dotted spec path, joints by name.
        start: its value in the spec (where the fit starts), in the spec's unit.
        lower, upper: bounds, same unit.
    """

    path: str
    start: float
    lower: float
    upper: float

    @property
    def log_scale(self) -> bool:
        """Searched on the log scale, log(value/start): a positive quantity (start > 0, lower
        bound >= 0). Otherwise on the linear scale, value/start."""
        return self.start > 0.0 and self.lower >= 0.0


def parse_parameters(texts: Iterable[str], spec: ManipulatorSpec) -> list[Parameter]:
    """Parameters from ``path`` or ``path[lo:hi]`` texts (either bound may be empty).

    Raises:
        SpecError: an unknown path, a value that is not a number, a start of 0 (a fit scales by
            it: set a start with --set), bounds that do not hold the start; one line each.
    """
    flat = flatten_spec(spec)
    out: list[Parameter] = []
    for text in texts:
        match = _BOUNDS.match(text.strip())
        if not match:
            raise SpecError(f"parameter {text!r}: expected PATH or PATH[LOW:HIGH]")
        path = _by_name(match["path"].strip(), spec)
        if path not in flat:
            raise SpecError(f"parameter {text!r}: {spec.name} has no value at {path!r} (a dotted "
                            "path as for --set, e.g. joints.q2.friction.coulomb)")
        start = flat[path]
        if isinstance(start, bool) or not isinstance(start, (int, float)):
            raise SpecError(f"parameter {path}: its value {start!r} is not a number")
        if start == 0.0:
            raise SpecError(f"parameter {path}: it starts at 0, and the fit scales each parameter "
                            "by its start: give a first guess with --set")
        lower = _bound(text, match["lo"], 0.0 if start > 0 else -math.inf)
        upper = _bound(text, match["hi"], math.inf if start > 0 else 0.0)
        if not lower <= start <= upper:
            raise SpecError(f"parameter {path}: its start {start:g} is outside [{lower:g}, "
                            f"{upper:g}]; give a start with --set")
        if any(p.path == path for p in out):
            raise SpecError(f"parameter {path} is given twice")
        out.append(Parameter(path, float(start), lower, upper))
    if not out:
        raise SpecError("no parameter to fit: give --params PATH,...")
    return out


def _by_name(path: str, spec: ManipulatorSpec) -> str:
    """``joints.<index>.…`` with the joint's name (the form :func:`flatten_spec` uses)."""
    parts = path.split(".")
    if len(parts) > 1 and parts[0] == "joints" and parts[1].isdigit():
        index = int(parts[1])
        if index < spec.n:
            parts[1] = spec.joint_names[index]
    return ".".join(parts)


def _bound(text: str, value: str | None, default: float) -> float:
    if value is None or not value.strip():
        return default
    try:
        return float(value)
    except ValueError:
        raise SpecError(f"parameter {text!r}: bound {value!r} is not a number") from None
