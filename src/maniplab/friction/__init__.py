"""Joint friction: its parameters and modes, and the laws the plant applies.

The laws themselves are C, where the plant steps (each law once, in the product's native code):

- **hybrid** stick/slip friction (the paper's eqs. 5-8) is a part of the plant's friction/limit
  automaton (``maniplab_native/plant.c``, see :mod:`maniplab.sim.plant`). SLIP: the friction
  opposes the motion, ``f = -(Fc + Fs exp(-(v/vs)²)) sign(v) - Fv v`` (Fc ``coulomb``, Fs
  ``static``, the stiction above Coulomb, vs ``stribeck_velocity``, Fv ``viscous``, which is
  MuJoCo's joint damping). SLIP -> STICK when |v| falls below ``stick_velocity`` while
  decelerating, or v changes sign within a step: the velocity is reset to zero and the joint is
  held. STICK: the friction is whatever holds the joint still (from the constrained dynamics of
  all held joints); STICK -> SLIP when that holding force exceeds the break-away force Fc + Fs.
  A joint with Fc + Fs = 0 has only viscous friction and never sticks;
- **LuGre** (Canudas de Wit et al. 1995) is the MuJoCo engine plugin ``maniplab.lugre``
  (``maniplab_native/lugre.c``; :mod:`~maniplab.friction.lugre`).
"""

from maniplab.friction.lugre import steady_force
from maniplab.friction.modes import FrictionMode
from maniplab.friction.params import Friction, FrictionModel

__all__ = [
    "Friction",
    "FrictionMode",
    "FrictionModel",
    "steady_force",
]
