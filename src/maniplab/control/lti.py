"""A discrete linear system from python-control as a controller: ``from_python_control``.

Design a controller with python-control (``control.c2d``, loop shaping, LQG, ...) and run it on
the plant: its inputs are the joint position errors ``q_ref(t) - q`` of the joints it controls,
its outputs their commands (valve current A, or force N / torque N·m), updated every ``sys.dt``
seconds and held in between.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from types import MappingProxyType
from typing import Any

import numpy as np

from maniplab.control.errors import ControlError
from maniplab.control.interface import Controller
from maniplab.control.trajectory import Trajectory


class LTIController(Controller):
    """x[k+1] = A x[k] + B e[k], u[k] = C x[k] + D e[k] with e = q_ref(t) - q on ``joints``.

    Args:
        A: the discrete state matrix, (s, s).
        B: the input matrix, (s, m).
        C: the output matrix, (m, s).
        D: the feedthrough matrix, (m, m).
        dt: the sample time, s.
        n: the arm's joints.
        joints: the m joints controlled, indices into the arm's joints.
        target: q_ref: joint positions (n,), rad or m, or a function t -> (n,).
        reference: the Cartesian reference the run is judged against (optional).
    """

    log_signals: Mapping[str, tuple[str, str]] = MappingProxyType(
        {"e": ("joint position errors q_ref - q of the controlled joints", "rad | m")})

    def __init__(self, A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, *, dt: float,
                 n: int, joints: Sequence[int], target: Any,
                 reference: Trajectory | None = None) -> None:
        self.A, self.B, self.C, self.D = (np.atleast_2d(np.asarray(m, dtype=float))
                                          for m in (A, B, C, D))
        self.dt, self.n, self.joints = float(dt), n, np.asarray(joints, dtype=int)
        self.target = target
        self.reference = reference
        self.reset()

    def reset(self, state: Any = None) -> None:
        """The system's state back to zero, the log emptied."""
        super().reset(state)
        self.x = np.zeros(self.A.shape[0])

    def q_ref(self, t: float) -> np.ndarray:
        """The joint reference at t, (n,)."""
        value = self.target(t) if callable(self.target) else self.target
        return np.asarray(value, dtype=float).reshape(self.n)

    def output(self, t: float, state: Any) -> np.ndarray:
        """The commands (n,): the system's output on the controlled joints, 0 elsewhere."""
        e = (self.q_ref(t) - np.asarray(state.q, dtype=float))[self.joints]
        y = self.C @ self.x + self.D @ e
        self.x = self.A @ self.x + self.B @ e
        self.log(e=e)
        u = np.zeros(self.n)
        u[self.joints] = y
        return u


def from_python_control(system: Any, spec: Any, target: Sequence[float] | Callable[[float], Any],
                        *, joints: Sequence[str | int] | None = None,
                        reference: Trajectory | None = None) -> LTIController:
    """A python-control discrete system (``StateSpace`` or ``TransferFunction`` with a numeric
    ``dt``) as a maniplab controller.

    Args:
        system: m inputs (the position errors of ``joints``), m outputs (their commands).
        spec: the arm (a spec, or anything with ``joint_names``).
        target: q_ref, joint positions (n,), rad or m, or a function t -> (n,).
        joints: the joints controlled, names or indices (default: all, in order).
        reference: the Cartesian reference the run's health verdict judges against.

    Raises:
        ControlError: a continuous system or one without a numeric sample time, or sizes that
            do not match the joints.
    """
    import control  # python-control: a core dependency, imported when used

    names = list(spec.joint_names)
    given = list(range(len(names))) if joints is None else [
        names.index(j) if isinstance(j, str) and j in names else j for j in joints]
    picked = [j for j in given if isinstance(j, int) and 0 <= j < len(names)]
    if len(picked) != len(given):
        raise ControlError(f"joints {joints!r}: expected names or indices of {', '.join(names)}")
    dt = system.dt
    if dt is None or dt is True or dt is False or not float(dt) > 0.0:
        raise ControlError(f"the system must be discrete with a sample time in seconds (dt = "
                           f"{dt!r}): discretise it with control.c2d(sys, dt) or give dt")
    ss = control.ss(system)
    m = len(picked)
    if ss.ninputs != m or ss.noutputs != m:
        raise ControlError(f"the system has {ss.ninputs} inputs and {ss.noutputs} outputs; "
                           f"{m} joints are controlled ({', '.join(names[j] for j in picked)})")
    return LTIController(ss.A, ss.B, ss.C, ss.D, dt=float(dt), n=len(names), joints=picked,
                         target=target, reference=reference)
