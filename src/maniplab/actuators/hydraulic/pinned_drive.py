"""How the cascade drives pinned two-chamber cylinders: the load-pressure loop and the inversion of
the four-edge valve.

For desired joint forces τ_d (from G1), per cylinder at the measured q, q̇, pA, pB:

1. domain transformation: the cylinder force F_d = τ_d / r(q), the desired load pressure
   p_Ld = F_d / A_A, and the load pressure p_L = pA - α pB (α = A_B / A_A): F = A_A p_L;
2. the load pressure's rate from the chambers' equations (``chambers.h``), with the valve at
   opening x::

       dp_L/dt = x D(x) - k_s ds/dt - (E/V_A + α E/V_B) Q_L
       D = E/V_A K_A g_A + α E/V_B K_B g_B,    k_s = E (A_A/V_A + α A_B/V_B)

   with g_A, g_B the orifice roots of the edges that x's sign opens (P→A and B→T, or P→B and
   A→T);
3. the loop (:class:`~.drive.PressureLoop` with k_s in place of the area and unit capacitance)
   asks dp_L/dt = dp_Ld/dt + ω_P (p_Ld - p_L) + ∫ + k_v k_s (ds/dt_ref - ds/dt), and the valve is
   inverted for it exactly: x = (that rate + k_s ds/dt + the leakage's) / D(x), the current
   i_v = x i_max. Each root is floored at ``valve_min_root`` sqrt(Ps - Pt) to keep x finite.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from maniplab.actuators.drive import CompiledDrive, ForceDrive
from maniplab.actuators.hydraulic import chambers
from maniplab.actuators.hydraulic.drive import PressureLoop

if TYPE_CHECKING:
    from maniplab.actuators.hydraulic.pinned import PinnedCylinder

Array = np.ndarray


class ChamberDrive(ForceDrive):
    """Pinned cylinders under the cascade: F_d = τ_d / r(q), the load-pressure loop, the valve
    inverted. Its gains are the controller settings' ``pressure`` section."""

    signals: ClassVar[dict[str, tuple[str, str]]] = {
        "pL_d": ("desired load pressure pA - (A_B/A_A) pB (NaN elsewhere)", "Pa"),
    }
    needs: ClassVar[tuple[str, ...]] = ("pA", "pB")

    def __init__(self, actuators: Sequence[Any], joints: Sequence[int], *, dt: float,
                 settings: Any) -> None:
        super().__init__(actuators, joints, dt=dt, settings=settings)
        self.cylinders: list[PinnedCylinder] = list(actuators)
        k = len(actuators)
        self.min_root = settings.valve_min_root
        g = settings.pressure
        self.loop = PressureLoop(np.ones(k), np.ones(k), np.zeros(k), dt=dt,
                                 bandwidth=g.bandwidth, integral=g.integral,
                                 speed_gain=g.speed_gain, rate_filter=g.rate_filter)

    def reset(self) -> None:
        super().reset()
        self.loop.reset()

    def command(self, force: Array, q: Array, qd: Array, qd_ref: Array,
                states: Mapping[str, Array]) -> Array:
        pa, pb = states["pA"], states["pB"]
        terms = [self._terms(c, float(x), float(p), float(b))
                 for c, x, p, b in zip(self.cylinders, q, pa, pb)]
        arm, ratio, stiff, leak, va, vb = (np.array(t) for t in zip(*terms))
        p_load = pa - ratio * pb
        p_desired = force / (arm * np.array([c.law.area_a for c in self.cylinders]))
        rate = self.loop.flow(p_desired, p_load, arm * qd, arm * qd_ref, area=stiff)
        need = rate + leak
        spool = np.array([n / self._opening_gain(c, *values, n) for c, n, values in
                          zip(self.cylinders, need, zip(pa, pb, va, vb))])
        self.log = {"pL_d": p_desired}
        return self.clip(np.array([chambers.spool_command(c.law, float(x))
                                   for c, x in zip(self.cylinders, spool)]))

    @staticmethod
    def _terms(c: PinnedCylinder, q: float, pa: float, pb: float) -> tuple[float, ...]:
        """(r, α, k_s, the leakage's term, V_A, V_B) at q: m, 1, Pa/m, Pa/s, m³, m³."""
        law = c.law
        s, r = float(c.geometry.length(q)), float(c.geometry.arm(q))
        _, _, va, vb = chambers.flows(law, np.array([pa, pb, 0.0]), s)
        ratio = law.area_b / law.area_a
        e = law.bulk_modulus
        stiff = e * (law.area_a / va + ratio * law.area_b / vb)
        leak = e * (1.0 / va + ratio / vb) * law.leakage * (pa - pb)
        return r, ratio, stiff, leak, va, vb

    def _opening_gain(self, c: PinnedCylinder, pa: float, pb: float, va: float, vb: float,
                      need: float) -> float:
        """D: dp_L/dt per unit opening in the direction ``need`` asks, Pa/s."""
        law = c.law
        sign = 1.0 if need >= 0.0 else -1.0
        q = chambers.flows(law, np.array([pa, pb, sign]), law.min_length)
        floor = self.min_root * np.sqrt(law.supply - law.tank)
        least_a = (law.gain_a if sign > 0 else law.out_a) * floor  # P->A or A->T
        least_b = (law.out_b if sign > 0 else law.gain_b) * floor  # B->T or P->B
        qa = sign * max(sign * q[0], least_a)
        qb = -sign * max(-sign * q[1], least_b)
        ratio = law.area_b / law.area_a
        return float(law.bulk_modulus * (qa / va - ratio * qb / vb)) * sign

    def compiled(self) -> CompiledDrive:
        """``chambers``: this drive in C (``cascade.c``'s chamber_drive): each cylinder's law and
        pins, the loop's gains (unit capacitance, no leakage: k_s is the loop's area), and the
        PID-only baseline's no-load inversion as ``area / valve_gain`` = i_max r_mid / v_piston."""
        loop = self.loop
        return CompiledDrive("chambers", {
            "chambers": [c.law for c in self.cylinders],
            "geometry": np.array([c.geometry.constants for c in self.cylinders]),
            "prismatic": np.array([int(c.joint.prismatic) for c in self.cylinders]),
            "area": np.array([c.params.valve.current_limit * c.mid_arm for c in self.cylinders]),
            "valve_gain": np.array([c.piston_speed() for c in self.cylinders]),
            "capacitance": loop._cap, "leakage": loop._leak, "pressure_kp": loop._kp,
            "pressure_ki": loop._ki, "min_root": self.min_root, "rate_alpha": loop._alpha,
            "speed_gain": loop.speed_gain, "compressibility": loop.compressibility})

    def speed_command(self, speed: Array) -> Array:
        """i_v = i_max r q̇ / (the piston's no-load speed), r at mid-range (its sign: a joint
        whose cylinder shortens as it turns moves forward on a negative current), clipped."""
        out = [c.params.valve.current_limit * v * c.mid_arm / c.piston_speed()
               for c, v in zip(self.cylinders, speed)]
        return self.clip(np.array(out))
