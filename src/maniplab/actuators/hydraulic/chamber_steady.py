"""Steady states of a pinned two-chamber cylinder: the pressures and spool opening that exert a
force while the joint moves at a constant speed.

With ds/dt = r(q) q̇ and F = τ / r(q), the chambers are steady when the valve's flows balance the
piston's and the leakage:

    Q_A(x, pA) = A_A ds/dt + Q_L          Q_B(x, pB) = -A_B ds/dt - Q_L       pA A_A - pB A_B = F

Three cases are tried, in order:

1. both balances met by the valve: pB follows from pA through the force, the A side's balance
   gives x, and pA is a root of the B side's (bracketed on a grid of pressures within [Pt, Ps]);
2. one chamber at tank pressure, its anti-cavitation valve making up what the valve does not
   pass (an overrunning load): x from the other side's balance;
3. the closest balance found in case 1, if it leaves at most MISMATCH of the valve's nominal flow
   unbalanced (a critically lapped valve with leakage across the piston has no exact steady state
   in a narrow band of creeping speeds, where the leakage lies between the two sides' flows).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy import optimize

from maniplab.actuators.hydraulic import chambers

if TYPE_CHECKING:
    from maniplab.actuators.hydraulic.pinned import PinnedCylinder

MISMATCH = 1e-3
"""The share of the valve's nominal flow case 3 may leave unbalanced."""

GRID = 65
"""Pressures at which case 1 looks for a sign change of the B side's balance."""


class SteadyFlows:
    """The balances of one cylinder at a force and speed (see the module).

    Args:
        cylinder: the actuator.
        force: joint force, N·m or N.
        q: joint position.
        v: joint speed.
    """

    def __init__(self, cylinder: PinnedCylinder, force: float, q: float, v: float) -> None:
        self.p, self.law = cylinder.params, cylinder.law
        self.s = float(cylinder.geometry.length(q))
        r = float(cylinder.geometry.arm(q))
        self.f, self.sdot = force / r, r * v
        self.aa, self.ab = self.law.area_a, self.law.area_b

    def needs(self, pa: float, pb: float) -> tuple[float, float]:
        """The flows into A and into B the steady chambers need, m³/s."""
        leak = self.p.leakage * (pa - pb)
        return self.aa * self.sdot + leak, -self.ab * self.sdot - leak

    def opening(self, pa: float, pb: float, side: int, need: float) -> float:
        """The opening x at which the valve passes ``need`` into side 0 (A) or 1 (B)."""
        way = math.copysign(1.0, need) * (1.0 if side == 0 else -1.0)
        full = chambers.flows(self.law, np.array([pa, pb, way]), self.s)[side]
        return way * need / full if full != 0.0 else math.copysign(math.inf, way)

    def shortfall(self, x: np.ndarray, side: int) -> float:
        """What the valve at opening x[2] leaves the chamber ``side`` short of, m³/s."""
        flows = chambers.flows(self.law, x, self.s)
        return self.needs(x[0], x[1])[side] - flows[side]

    def with_a(self, pa: float) -> np.ndarray:
        """(pA, pB, x) with pB from the force and x from the A side's balance."""
        pb = (pa * self.aa - self.f) / self.ab
        return np.array([pa, pb, self.opening(pa, pb, 0, self.needs(pa, pb)[0])])

    def solve(self) -> np.ndarray | None:
        """(pA, pB, x) of the first case that holds (x may be beyond ±1), or None."""
        for case in (self.balanced, self.cavitating, self.nearly_balanced):
            x = case()
            if x is not None:
                return x
        return None

    def _grid(self) -> tuple[np.ndarray, np.ndarray]:
        p = self.p
        low = max(p.tank_pressure, (self.f + p.tank_pressure * self.ab) / self.aa)
        high = min(p.supply_pressure, (self.f + p.supply_pressure * self.ab) / self.aa)
        grid = np.linspace(low, high, GRID) if low < high else np.array([low])
        return grid, self._balances_b(grid)

    def _balances_b(self, pa: np.ndarray) -> np.ndarray:
        """At each cap pressure of ``pa`` (K,), with pB from the force and the opening from the A
        side's balance: what the valve leaves the B side short of, m³/s (±inf where no opening
        passes A's need); two calls of the valve law for all."""
        pb = (pa * self.aa - self.f) / self.ab
        leak = self.p.leakage * (pa - pb)
        need_a, need_b = self.aa * self.sdot + leak, -self.ab * self.sdot - leak
        way = np.where(np.signbit(need_a), -1.0, 1.0)  # as math.copysign(1.0, need)
        full = chambers.valve_flows(self.law, np.stack([pa, pb, way], axis=1))[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(full != 0.0, way * need_a / np.where(full != 0.0, full, 1.0),
                         np.copysign(np.inf, way))
        finite = np.isfinite(x)
        got = chambers.valve_flows(self.law, np.stack([pa, pb, np.where(finite, x, 0.0)],
                                                      axis=1))[:, 1]
        return np.where(finite, need_b - got, np.copysign(np.inf, -x))

    def _balance_b(self, pa: float) -> float:
        """:meth:`_balances_b` at one cap pressure, m³/s."""
        return float(self._balances_b(np.array([pa]))[0])

    def balanced(self) -> np.ndarray | None:
        """Case 1."""
        grid, values = self._grid()
        finite = np.isfinite(values[:-1]) & np.isfinite(values[1:])  # (no opening passes at
        change = np.flatnonzero(finite & (values[:-1] * values[1:] <= 0.0))  # a chamber at tank)
        if not change.size:
            return None
        k = int(change[0])
        root = optimize.brentq(self._balance_b, grid[k], grid[k + 1],
                               xtol=1e-9 * float(grid[-1]), rtol=1e-14)
        return self.with_a(root)

    def cavitating(self) -> np.ndarray | None:
        """Case 2: A at tank fed by its anti-cavitation valve, or B."""
        tank = self.p.tank_pressure
        for side in (0, 1):
            pa = tank if side == 0 else (self.f + tank * self.ab) / self.aa
            pb = (tank * self.aa - self.f) / self.ab if side == 0 else tank
            if min(pa, pb) < tank:
                continue
            other = 1 - side
            x = np.array([pa, pb, self.opening(pa, pb, other, self.needs(pa, pb)[other])])
            if math.isfinite(x[2]) and self.shortfall(x, side) >= 0.0:
                return x
        return None

    def nearly_balanced(self) -> np.ndarray | None:
        """Case 3."""
        grid, values = self._grid()
        best = int(np.argmin(np.where(np.isfinite(values), np.abs(values), np.inf)))
        x = self.with_a(float(grid[best]))
        if not math.isfinite(x[2]):
            return None
        return x if abs(values[best]) <= MISMATCH * self.p.valve.nominal_flow else None
