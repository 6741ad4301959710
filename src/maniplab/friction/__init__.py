"""Joint friction: its parameters, the hybrid stick/slip laws (the paper's eqs. 5-8) and LuGre.

The laws are here; the automaton that applies them inside a step (holding stuck joints, deciding
break-aways and stops) is a part of the plant, :mod:`maniplab.sim.automaton`.
"""

from maniplab.friction.hybrid import HybridFriction, slip_force, sticks
from maniplab.friction.lugre import LuGreFriction, LuGreJoint, steady_force
from maniplab.friction.modes import FrictionMode
from maniplab.friction.params import Friction, FrictionModel

__all__ = [
    "Friction",
    "FrictionMode",
    "FrictionModel",
    "HybridFriction",
    "LuGreFriction",
    "LuGreJoint",
    "slip_force",
    "steady_force",
    "sticks",
]
