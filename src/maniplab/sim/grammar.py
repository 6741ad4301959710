"""The command line's text forms of inputs, overrides and sweep values.

Input grammar (``--input``)::

    JOINT=TERM[+TERM...]
    TERM = NUMBER                          constant
         | step:AMPLITUDE[@T0]             0 before T0, AMPLITUDE from T0 on
         | impulse:AREA[,WIDTH][@T0]       a pulse of AREA (value x s) lasting WIDTH (default 1 ms)
         | sine:AMPLITUDE,FREQUENCY[,PHASE][@T0]   FREQUENCY in Hz, PHASE in rad
         | ramp:SLOPE[,T1][@T0]            rising SLOPE per second from T0 (until T1)
         | constant:VALUE

e.g. ``q2=step:1.5@0.2``, ``q1=0.1+sine:0.05,2``. Values are valve currents (A) on hydraulic
joints and forces (N) or torques (N·m) on torque joints. Overrides (``--set PATH=VALUE``) and sweep
values (``--vary PATH=V1,V2,...``) are YAML scalars: ``4000``, ``1e-11``, ``[0, 0, -9.81]``.
"""

from __future__ import annotations

import re
from typing import Any

from maniplab.errors import ManiplabError
from maniplab.sim import signals
from maniplab.spec.yaml_io import parse_yaml

#: signal kind -> (constructor, its value arguments in order, how many are required)
_KINDS: dict[str, tuple[Any, tuple[str, ...], int]] = {
    "step": (signals.step, ("amplitude",), 1),
    "impulse": (signals.impulse, ("area", "width"), 1),
    "sine": (signals.sine, ("amplitude", "frequency", "phase"), 2),
    "ramp": (signals.ramp, ("slope", "t1"), 1),
    "constant": (signals.constant, ("value",), 1),
}
_PLUS = re.compile(r"(?<![eE])\+")  # a '+' that is not an exponent's sign
_TERM = re.compile(r"^(?:(?P<kind>[a-z]+):)?(?P<args>[^@]+)(?:@(?P<t0>.+))?$")


class GrammarError(ManiplabError):
    """A command-line input, override or sweep value is malformed."""


def parse_input(text: str) -> tuple[str, signals.Signal]:
    """``"q2=step:1.5@0.2"`` -> ``("q2", step(1.5, t0=0.2))``; raises GrammarError."""
    joint, sep, expression = text.partition("=")
    if not sep or not joint.strip() or not expression.strip():
        raise GrammarError(f"input {text!r}: expected JOINT=SIGNAL, e.g. q2=step:1.5@0.2")
    terms = [_term(text, part.strip()) for part in _PLUS.split(expression)]
    total = terms[0]
    for term in terms[1:]:
        total = total + term
    return joint.strip(), total


def _term(text: str, part: str) -> signals.Signal:
    match = _TERM.match(part)
    if not match:
        raise GrammarError(f"input {text!r}: cannot read {part!r}; expected e.g. step:1.5@0.2, "
                           f"sine:0.1,2 or a number")
    kind, t0 = match["kind"], match["t0"]
    args = [_number(text, a) for a in match["args"].split(",")]
    if kind is None:
        if len(args) != 1 or t0 is not None:
            raise GrammarError(f"input {text!r}: {part!r} is not a number; name the signal "
                               f"(step:, impulse:, sine:, ramp:, constant:)")
        return signals.constant(args[0])
    if kind not in _KINDS:
        raise GrammarError(f"input {text!r}: unknown signal {kind!r}; expected "
                           f"{', '.join(_KINDS)}")
    make, names, required = _KINDS[kind]
    if not required <= len(args) <= len(names):
        count = ",".join(names[:required]) + "".join(f"[,{n}]" for n in names[required:])
        raise GrammarError(f"input {text!r}: expected {kind}:{count}, got {len(args)} values")
    values = dict(zip(names, args))
    if t0 is not None:
        if kind == "constant":
            raise GrammarError(f"input {text!r}: constant takes no @T0; use step:VALUE@T0")
        values["t0"] = _number(text, t0)
    return make(**values)


def _number(text: str, token: str) -> float:
    try:
        return float(token)
    except ValueError:
        raise GrammarError(f"input {text!r}: {token.strip()!r} is not a number") from None


def parse_assignment(text: str, what: str = "--set") -> tuple[str, Any]:
    """``"end_effector.mass=4000"`` -> ``("end_effector.mass", 4000)`` (value read as YAML)."""
    path, sep, value = text.partition("=")
    if not sep or not path.strip() or not value.strip():
        raise GrammarError(f"{what} {text!r}: expected PATH=VALUE, e.g. end_effector.mass=4000")
    return path.strip(), _yaml_value(text, value, what)


def parse_variation(text: str) -> tuple[str, list[Any]]:
    """``"end_effector.mass=3000,4000"`` -> ``("end_effector.mass", [3000, 4000])``; vectors in
    brackets stay whole: ``gravity=[0,0,-9.81],[0,-9.81,0]``."""
    path, sep, raw = text.partition("=")
    if not sep or not path.strip() or not raw.strip():
        raise GrammarError(f"--vary {text!r}: expected PATH=V1,V2,..., e.g. end_effector.mass=3000,4000")
    return path.strip(), [_yaml_value(text, item, "--vary") for item in _split_top_level(raw)]


def _split_top_level(raw: str) -> list[str]:
    """Split at commas outside brackets: ``1,[0,0,1],2`` -> ``['1', '[0,0,1]', '2']``."""
    parts, depth, current = [], 0, ""
    for char in raw:
        depth += char in "[{"
        depth -= char in "]}"
        if char == "," and depth == 0:
            parts.append(current)
            current = ""
        else:
            current += char
    return [*parts, current]


def _yaml_value(text: str, value: str, what: str) -> Any:
    try:
        data, _ = parse_yaml(value.strip())
    except ManiplabError as exc:
        raise GrammarError(f"{what} {text!r}: cannot read the value ({exc})") from None
    return data
