"""How the cascade drives hydraulic joints: the paper's inner pressure loop and the valve inversion.

For desired joint forces τ_d (from G1), per hydraulic joint:

1. domain transformation: ΔP_d = τ_d / A (joint force = A ΔP, eq. 4);
2. the pressure loop (:class:`PressureLoop`): ΔP_d -> oil-flow command Φ;
3. G2: Φ -> valve current i_v, the valve law inverted (:func:`~.valve.valve_current`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from maniplab.actuators.drive import CompiledDrive, ForceDrive
from maniplab.actuators.hydraulic.valve import valve_current

if TYPE_CHECKING:
    from maniplab.actuators.base import ActuatorPlugin

Array = NDArray[np.float64]


class PressureLoop:
    """Inner loop of the cascade: desired ΔP_d -> oil-flow command Φ, one per hydraulic joint.

    From eq. (4), (V/E) dΔP/dt = Q - Le ΔP - A q̇. The flow command makes ΔP follow ΔP_d:

        Φ = A q̇ + Le ΔP + (V/E) dΔP_d/dt                      (flow the moving piston needs,
                                                                leakage, compressibility)
            + Kp_P (ΔP_d - ΔP) + Ki_P ∫(ΔP_d - ΔP) dt        (pressure error)
            + k_v A (q̇_ref - q̇)                              (speed error)

    With Kp_P = ω_P V/E the pressure error decays at the loop's bandwidth ω_P (rad/s) on every
    joint, whatever its size; Ki_P = ω_I Kp_P. dΔP_d/dt is the backward difference of ΔP_d,
    low-pass filtered with time constant ``rate_filter``. The speed term feeds part of the velocity
    error straight into flow, as a hydraulic servo does: at k_v = 1 the piston flow is A q̇_ref.

    Args:
        area: A, m² or m³/rad, (k,).
        capacitance: V/E, m³/Pa, (k,).
        leakage: Le, m³/(s·Pa), (k,).
        dt: sample time, s.
        bandwidth: ω_P, rad/s.
        integral: ω_I (Ki_P = ω_I Kp_P), 1/s; 0 for none.
        speed_gain: k_v, dimensionless.
        rate_filter: time constant of the dΔP_d/dt filter, s.
        compressibility: include the (V/E) dΔP_d/dt term.
    """

    def __init__(self, area: ArrayLike, capacitance: ArrayLike, leakage: ArrayLike, *, dt: float,
                 bandwidth: float = 60.0, integral: float = 0.0, speed_gain: float = 0.0,
                 rate_filter: float = 0.005, compressibility: bool = True) -> None:
        self._area = np.asarray(area, dtype=float)
        self._cap = np.asarray(capacitance, dtype=float)
        self._leak = np.asarray(leakage, dtype=float)
        self._kp = bandwidth * self._cap
        self._ki = integral * self._kp
        self.speed_gain = float(speed_gain)
        self.compressibility = compressibility
        self.dt = dt
        self._alpha = dt / (rate_filter + dt)
        self.reset()

    def reset(self) -> None:
        """Clear the integrator and the ΔP_d rate filter."""
        self._prev: Array | None = None
        self._rate = np.zeros_like(self._area)
        self._integral = np.zeros_like(self._area)

    def flow(self, dP_d: ArrayLike, dP: ArrayLike, qd: ArrayLike,
             qd_ref: ArrayLike | None = None, area: ArrayLike | None = None) -> Array:
        """One sample of the loop: Φ, m³/s, (k,).

        Args:
            dP_d: desired ΔP, Pa, (k,).
            dP: measured ΔP, Pa, (k,).
            qd: joint velocities, rad/s or m/s, (k,).
            qd_ref: reference joint velocities for the speed error, (k,) (default ``qd``).
            area: A at this sample, (k,), where it changes with the pose (default: the one
                given at construction).
        """
        dP_d, dP, qd = (np.asarray(a, dtype=float) for a in (dP_d, dP, qd))
        if area is not None:
            self._area = np.asarray(area, dtype=float)
        if self._prev is not None:
            self._rate += self._alpha * ((dP_d - self._prev) / self.dt - self._rate)
        self._prev = dP_d
        error = dP_d - dP
        flow = self._area * qd + self._leak * dP + self._kp * error + self._integral
        self._integral = self._integral + self.dt * self._ki * error
        if self.compressibility:
            flow += self._cap * self._rate
        if qd_ref is not None and self.speed_gain:
            flow += self.speed_gain * self._area * (np.asarray(qd_ref, dtype=float) - qd)
        return np.asarray(flow, dtype=float)


class PressureDrive(ForceDrive):
    """Hydraulic joints under the cascade: ΔP_d = τ_d / A, the pressure loop, G2.

    Its gains are the controller settings' ``pressure`` section; the valve inversion's root is
    floored at ``valve_min_root``.
    """

    signals: ClassVar[dict[str, tuple[str, str]]] = {
        "dP_d": ("desired differential pressure (NaN at joints without a cylinder)", "Pa"),
        "phi": ("flow command Φ (NaN at joints without a cylinder)", "m³/s"),
    }
    needs: ClassVar[tuple[str, ...]] = ("dP",)

    def __init__(self, actuators: Sequence[ActuatorPlugin], joints: Sequence[int], *, dt: float,
                 settings: Any) -> None:
        super().__init__(actuators, joints, dt=dt, settings=settings)
        params = [a.params for a in actuators]
        self.area = np.array([p.area for p in params])
        self.gain = np.array([p.valve_gain for p in params])
        self.supply = np.array([p.supply_pressure for p in params])
        self.orifice = np.array([p.orifice for p in params])
        self.min_root = settings.valve_min_root
        g = settings.pressure
        self.loop = PressureLoop(self.area, [p.volume / p.bulk_modulus for p in params],
                                 [p.leakage for p in params], dt=dt, bandwidth=g.bandwidth,
                                 integral=g.integral, speed_gain=g.speed_gain,
                                 rate_filter=g.rate_filter)

    def reset(self) -> None:
        super().reset()
        self.loop.reset()

    def command(self, force: Array, q: Array, qd: Array, qd_ref: Array,
                states: Mapping[str, Array]) -> Array:
        dP = states["dP"]
        dP_d = force / self.area
        phi = self.loop.flow(dP_d, dP, qd, qd_ref)
        self.log = {"dP_d": dP_d, "phi": phi}
        return valve_current(phi, dP, self.gain, self.supply, self.limit,
                             min_root=self.min_root, orifice=self.orifice)

    def speed_command(self, speed: Array) -> Array:
        """i_v = v A / C, the no-load valve inversion, clipped."""
        return self.clip(speed * self.area / self.gain)

    def compiled(self) -> CompiledDrive:
        """``valve``: this drive's pressure loop and G2 in C, with its gains and parameters."""
        loop = self.loop
        return CompiledDrive("valve", {
            "area": self.area, "valve_gain": self.gain, "supply": self.supply,
            "orifice": self.orifice, "capacitance": loop._cap, "leakage": loop._leak,
            "pressure_kp": loop._kp, "pressure_ki": loop._ki, "min_root": self.min_root,
            "rate_alpha": loop._alpha, "speed_gain": loop.speed_gain,
            "compressibility": loop.compressibility})
