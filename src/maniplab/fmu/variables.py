"""The FMU's variables: inputs, outputs and parameters, with units and descriptions.

Names are ``<what>.<joint>`` (``u.q2``, ``q.q2``, ``dP.q2``, ``leakage.q2``; the payload is
``payload``). A value reference is the variable's position in :func:`variables`' list, and its
kind and index tell the FMU's C code where the value lives (``fmu.c``'s ``ML_V_*``).
"""

from __future__ import annotations

import dataclasses

from maniplab.fmu.template import Parameter
from maniplab.sim.plant import Plant

UNITS: dict[str, dict[str, int]] = {
    "m": {"m": 1}, "rad": {"rad": 1}, "m/s": {"m": 1, "s": -1}, "rad/s": {"rad": 1, "s": -1},
    "Pa": {"kg": 1, "m": -1, "s": -2}, "m3/s": {"m": 3, "s": -1}, "A": {"A": 1},
    "N": {"kg": 1, "m": 1, "s": -2}, "N.m": {"kg": 1, "m": 2, "s": -2}, "kg": {"kg": 1},
    "m3/(s.Pa)": {"kg": -1, "m": 4, "s": 1}, "N.s/m": {"kg": 1, "s": -1},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1}, "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
}
"""The FMI units the variables use: name -> SI base-unit exponents (``<BaseUnit>``)."""

_STATE_UNITS = {"Pa": "Pa", "m³/s": "m3/s"}

_STATES = {
    "dP": "differential pressure across joint {}'s piston",
    "Q": "valve flow of joint {}'s cylinder",
    "pA": "cap-side chamber pressure of joint {}'s cylinder",
    "pB": "rod-side chamber pressure of joint {}'s cylinder",
    "spool": "spool position of joint {}'s valve (-1 to 1)",
    "z": "LuGre bristle deflection of joint {}",
}

MODES = "0 slipping, 1 stuck, 2 on its lower limit, 3 on its upper limit"


@dataclasses.dataclass(frozen=True)
class Variable:
    """One FMI scalar variable.

    Attributes:
        name: its name.  kind: ``q``, ``qd``, ``act``, ``mode``, ``u``, ``param`` or ``q0``.
        index: the joint (q, qd, mode, u, q0), the activation address (act) or the parameter.
        causality: ``input``, ``output`` or ``parameter``.  type: ``Real`` or ``Integer``.
        unit: an FMI unit name (:data:`UNITS`) or "" for none.
        start: the start value (inputs, parameters), else None.
        description: one line.
    """

    name: str
    kind: str
    index: int
    causality: str
    type: str
    unit: str
    start: float | None
    description: str


def variables(plant: Plant, params: list[Parameter]) -> list[Variable]:
    """Inputs, then outputs, then parameters; value reference = position."""
    return _inputs(plant) + _outputs(plant) + _parameters(plant, params)


def _motion_units(plant: Plant, j: int) -> tuple[str, str]:
    return ("m", "m/s") if plant.spec.joints[j].prismatic else ("rad", "rad/s")


def _inputs(plant: Plant) -> list[Variable]:
    out = []
    for j, (joint, act) in enumerate(zip(plant.joint_names, plant.actuators)):
        unit = act.command_unit if act.command_unit in UNITS else ""
        if act.command_unit == "N | N·m":
            unit = "N" if plant.spec.joints[j].prismatic else "N.m"
        what = {"A": "valve current", "V": "valve voltage from neutral", "N": "force",
                "N.m": "torque"}.get(unit, "command")
        limit = "" if act.command_limit is None else f" to ±{act.command_limit:g} {unit}"
        out.append(Variable(f"u.{joint}", "u", j, "input", "Real", unit, 0.0,
                            f"{what} of joint {joint}'s actuator, held over each step, clipped"
                            f"{limit}"))
    return out


def _outputs(plant: Plant) -> list[Variable]:
    names = plant.joint_names
    out = []
    for j, joint in enumerate(names):
        unit, rate = _motion_units(plant, j)
        out.append(Variable(f"q.{joint}", "q", j, "output", "Real", unit, None,
                            f"position of joint {joint}"))
        out.append(Variable(f"qd.{joint}", "qd", j, "output", "Real", rate, None,
                            f"velocity of joint {joint}"))
    for name, (joints, adrs) in plant.layout.items():
        for j, adr in zip(joints.tolist(), adrs.tolist()):
            out.append(Variable(f"{name}.{names[j]}", "act", adr, "output", "Real",
                                _state_unit(plant, j, name), None,
                                _STATES.get(name, "state " + name + " of joint {}'s actuator")
                                .format(names[j])))
    for j, joint in enumerate(names):
        out.append(Variable(f"mode.{joint}", "mode", j, "output", "Integer", "", None,
                            f"friction/limit mode of joint {joint}: {MODES}"))
    return out


def _state_unit(plant: Plant, j: int, name: str) -> str:
    if name == "z":
        return _motion_units(plant, j)[0]
    act = plant.actuators[j]
    return _STATE_UNITS.get(act.state_units[act.states.index(name)], "")


def _parameters(plant: Plant, params: list[Parameter]) -> list[Variable]:
    out = [Variable(p.name, "param", i, "parameter", "Real", p.unit, p.default,
                    f"{p.description} (the spec's {p.override})")
           for i, p in enumerate(params)]
    for j, joint in enumerate(plant.joint_names):
        out.append(Variable(f"q0.{joint}", "q0", j, "parameter", "Real",
                            _motion_units(plant, j)[0], 0.0,
                            f"initial position of joint {joint} (put on its limits if beyond)"))
    return out
