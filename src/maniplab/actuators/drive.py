"""Drives: how a controller makes a group of joints exert the forces it wants.

A force controller (the cascade's G1) computes a desired force (N) or torque (N·m) per joint; a
drive turns those into the commands of the joints' actuators. Each actuator class gives the drive
of its joints (:meth:`~maniplab.actuators.base.ActuatorPlugin.drive`): the hydraulic cylinder's
is the paper's inner pressure loop with the valve inversion G2
(:class:`~maniplab.actuators.hydraulic.drive.PressureDrive`); any actuator that declares
:meth:`~maniplab.actuators.base.ActuatorPlugin.steady` is driven by :class:`StaticDrive`, which
inverts its steady state at each sample (a torque source passes the force through; a DC motor
gets the voltage of the steady current at the measured speed).

The built-in drives also say how the compiled cascade runs them (:meth:`ForceDrive.compiled`):
then the controller's whole sample is C, and the plant's run loop calls it with no Python.
"""

from __future__ import annotations

import abc
import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

if TYPE_CHECKING:
    from maniplab.actuators.base import ActuatorPlugin


@dataclasses.dataclass(frozen=True)
class CompiledDrive:
    """A drive's law as the compiled cascade (``maniplab_native/cascade.h``) runs it itself.

    Attributes:
        kind: "valve" (the pressure loop and G2 of
            :class:`~maniplab.actuators.hydraulic.drive.PressureDrive`) or "force" (the command is
            the force, clipped: :class:`ForceSourceDrive`).
        parameters: the law's parameters by name (those of ``ml_cascade_config``): arrays (k,)
            over the drive's joints, or scalars.
    """

    kind: str
    parameters: Mapping[str, Any] = dataclasses.field(default_factory=dict)


class ForceDrive(abc.ABC):
    """Turns desired joint forces into actuator commands for k joints (one actuator class).

    Class attributes:
        signals: what the drive logs at each sample, name -> (description, unit); the values
            of the last sample are in :attr:`log` (each (k,)).
        needs: the measured actuator states it reads (e.g. ``("dP",)``).

    Args:
        actuators: the k actuators.
        joints: their joint indices in the arm, (k,).
        dt: the controller's sample time, s.
        settings: the controller's settings (the spec's ``control:`` section).

    Attributes:
        joints: indices (k,).  limit: command limits (k,) (inf: none).
    """

    signals: ClassVar[dict[str, tuple[str, str]]] = {}
    needs: ClassVar[tuple[str, ...]] = ()

    def __init__(self, actuators: Sequence[ActuatorPlugin], joints: Sequence[int], *, dt: float,
                 settings: Any) -> None:
        self.actuators = list(actuators)
        self.joints = np.asarray(joints, dtype=int)
        self.dt = dt
        self.limit = np.array([math.inf if a.command_limit is None else a.command_limit
                               for a in actuators])
        self.log: dict[str, np.ndarray] = {}

    def reset(self) -> None:
        """Forget the past (filters, integrators)."""
        self.log = {}

    @abc.abstractmethod
    def command(self, force: np.ndarray, q: np.ndarray, qd: np.ndarray, qd_ref: np.ndarray,
                states: Mapping[str, np.ndarray]) -> np.ndarray:
        """The commands, (k,), clipped to the limits, for the desired forces.

        Args:
            force: desired joint forces, N or N·m, (k,).
            q: measured joint positions, (k,).
            qd: measured joint velocities, (k,).
            qd_ref: the reference joint velocities, (k,).
            states: the measured actuator states by name (e.g. ``dP``), each (k,).
        """

    def speed_command(self, speed: np.ndarray) -> np.ndarray | None:
        """Commands that move the unloaded joints at ``speed``, (k,), or None when the actuator
        is not speed-controlled by nature (a valve is; a torque source is not)."""
        return None

    def clip(self, u: np.ndarray) -> np.ndarray:
        """u clipped to ±limit."""
        return np.minimum(np.maximum(u, -self.limit), self.limit)

    def compiled(self) -> CompiledDrive | None:
        """The drive's law for the compiled cascade, or None (the default): the cascade then
        computes the desired forces (or, in its PID-only mode, the joint speeds) in C and calls
        :meth:`command` (and :meth:`speed_command`) from Python for these joints."""
        return None


class StaticDrive(ForceDrive):
    """Each sample, the command of :meth:`~ActuatorPlugin.steady` for the desired force at the
    measured position and speed (no feedback of the actuator's states)."""

    def command(self, force: np.ndarray, q: np.ndarray, qd: np.ndarray, qd_ref: np.ndarray,
                states: Mapping[str, np.ndarray]) -> np.ndarray:
        u = np.array([a.steady(float(f), float(x), float(v)).u
                      for a, f, x, v in zip(self.actuators, force, q, qd)])
        return self.clip(u)


class ForceSourceDrive(StaticDrive):
    """The drive of an ideal force source (whose steady state is the force itself): the command
    is the desired force, clipped. The compiled cascade runs it in C."""

    def command(self, force: np.ndarray, q: np.ndarray, qd: np.ndarray, qd_ref: np.ndarray,
                states: Mapping[str, np.ndarray]) -> np.ndarray:
        return self.clip(np.asarray(force, dtype=float))

    def compiled(self) -> CompiledDrive:
        """``force``: clip(τ_d) in C."""
        return CompiledDrive("force")
