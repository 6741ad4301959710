"""Mode transitions of the held joints: stuck by stiction, or resting on a limit.

At the start of each step the plant knows the force that holds each held joint still at that
instant (the paper's eq. 8: the held joints' part of the constrained dynamics under the step's
forces, see :meth:`~maniplab.sim.plant.Plant._settle`). :func:`transitions` applies the rules:

- AT_UPPER is released when the stop had to pull (hold > 0), AT_LOWER when hold < 0; the joint
  becomes STICK if it has stick/slip friction (it may still be held by stiction), else SLIP;
- STICK breaks away (-> SLIP) when |hold| exceeds the break-away force Fc + Fs; it starts slipping
  in the direction the other forces push it (opposite to the hold).

Limits are decided first: when any limit releases, break-aways wait, because the other holding
forces were computed with that (one-sided, wrongly active) constraint in place; the plant
evaluates the holding forces again without it, in the same step, and calls this again.
"""

from __future__ import annotations

from collections.abc import Sequence

from maniplab.actuators.modes import FrictionMode

_STICK, _SLIP = FrictionMode.STICK.value, FrictionMode.SLIP.value
_LOWER, _UPPER = FrictionMode.AT_LOWER.value, FrictionMode.AT_UPPER.value


def transitions(mode: Sequence[int], hold: Sequence[float], breakaway: Sequence[float],
                can_stick: Sequence[bool]) -> tuple[list[int], list[float]]:
    """New modes of k held joints and the slip direction of those that broke away.

    Args:
        mode: their modes (STICK, AT_LOWER or AT_UPPER values), (k,).
        hold: the force that held each one, along the joint's axis, N or N·m, (k,).
        breakaway: Fc + Fs of each, N or N·m, (k,).
        can_stick: whether each has stick/slip friction, (k,).

    Returns:
        (mode, direction), each (k,): the new modes, and ±1 for a joint that broke away (the sign
        of its coming motion), 0 for the others.
    """
    k = len(mode)
    new = list(mode)
    direction = [0.0] * k
    released = False
    for i in range(k):
        if (mode[i] == _UPPER and hold[i] > 0.0) or (mode[i] == _LOWER and hold[i] < 0.0):
            new[i] = _STICK if can_stick[i] else _SLIP
            released = True
    if released:
        return new, direction
    for i in range(k):
        if mode[i] == _STICK and abs(hold[i]) > breakaway[i]:
            new[i] = _SLIP
            direction[i] = -1.0 if hold[i] > 0.0 else 1.0
    return new, direction
