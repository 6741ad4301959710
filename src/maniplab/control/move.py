"""A point-to-point move, planned, run under the controller and judged: what ``maniplab control``
does, as one function."""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from maniplab.control.cascade import CascadeController
from maniplab.control.interface import TOLERANCES
from maniplab.control.metrics import TrackingMetrics, tracking_metrics
from maniplab.control.point_to_point import MovePlan, plan_move
from maniplab.model import AnalyticModel
from maniplab.sim.health import Health
from maniplab.sim.run import Run
from maniplab.sim.simulate import simulate
from maniplab.spec import ManipulatorSpec

ControllerFactory = Callable[..., Any]
"""Makes a move's controller: ``factory(spec, move) -> controller``; a factory with a keyword
parameter ``joint_path`` also gets the planned joint path, ``joint_path(t) -> (q, q̇)``."""


@dataclasses.dataclass(frozen=True)
class MoveResult:
    """A move that ran.

    Attributes:
        plan: the checked plan (the move, possibly stretched).
        run: the closed-loop run (the controller's log in it).
        metrics: how well it followed the move.
    """

    plan: MovePlan
    run: Run
    metrics: TrackingMetrics

    @property
    def health(self) -> Health:
        """The run's health verdict."""
        return self.run.health

    def missed(self, final: float = TOLERANCES[0], rms: float = TOLERANCES[1]) -> str | None:
        """None when the move met its tolerances (mm) and the run is healthy, else one line:
        what was missed, and the cause and the setting to change (the run's worst finding)."""
        m, health = self.metrics, self.health
        misses = []
        if not m.final_error_mm <= final:
            misses.append(f"final error {m.final_error_mm:.3g} mm > {final:g} mm")
        if not m.rms_error_mm <= rms:
            misses.append(f"RMS error {m.rms_error_mm:.3g} mm > {rms:g} mm")
        failed = [f for f in health.findings
                  if f.severity.value == "failure" and f.check != "tracking"]
        if not misses and not failed:
            return None
        what = ("the move missed its tolerances (" + ", ".join(misses) + ")" if misses
                else "the run failed its health check")
        causes = [f for f in health.findings if f.check != "tracking"]  # the miss itself
        if causes:
            return f"{what}: {causes[0].line()}"
        gains = ("the baseline's joint gains (control.pid_only.kp, .ki)"
                 if self.run.label.startswith("pid") else
                 "the outer gains (control.position)" if self.run.label.startswith("cascade")
                 else "your controller's gains")
        return (f"{what}: {self._farthest_joint()}; no actuator reached a limit: raise {gains} "
                "or check the controller's model of the arm (payload, friction)")

    def _farthest_joint(self) -> str:
        """The joint that ends farthest from its planned goal, relative to its range."""
        q, goal = np.asarray(self.run.q)[-1], np.asarray(self.plan.q_goal)
        lower = np.array([j.limits[0] if j.limits else -np.pi for j in self.run.spec.joints])
        upper = np.array([j.limits[1] if j.limits else np.pi for j in self.run.spec.joints])
        off = np.abs(q - goal) / np.maximum(upper - lower, 1e-9)
        j = int(np.argmax(off))
        unit = "m" if self.run.spec.joints[j].type.value == "P" else "rad"
        return (f"joint {self.run.spec.joint_names[j]} ends {q[j] - goal[j]:+.3g} {unit} from "
                "its planned goal")


def run_move(spec: ManipulatorSpec, target: Sequence[float], *, start: Sequence[float] | None,
             duration: float, mode: str = "cascade", fit_mode: str = "stretch",
             settle: float = 1.0, model: AnalyticModel | None = None,
             sample_dt: float | None = None, controller: ControllerFactory | None = None,
             tolerances: tuple[float, float] = TOLERANCES,
             plant: ManipulatorSpec | None = None) -> MoveResult:
    """Plan a move to ``target`` (:func:`~maniplab.control.point_to_point.plan_move`), run it
    from rest with the actuators holding the arm against gravity, and measure it.

    Args:
        spec: the arm; its ``control:`` section, completed from the arm, sets the controller.
        target: as for ``plan_move``.
        start: as for ``plan_move``.
        duration: as for ``plan_move``.
        fit_mode: as for ``plan_move``.
        mode: "cascade" or "pid" (the PID-only baseline), when ``controller`` is None.
        settle: time simulated after the move, s.
        model: the arm's analytic model.
        sample_dt: the run's recording interval, s (default: every step, as ``simulate``).
        controller: your own controller instead: a factory ``controller(spec, move)`` (a
            class such as a :class:`~maniplab.control.interface.Controller` subclass) given the
            arm and the planned move (a :class:`~maniplab.control.trajectory.Trajectory`),
            returning the controller (see :mod:`~maniplab.control.interface`); a factory with
            a keyword parameter ``joint_path`` also gets the planned joint path.
        tolerances: (final, RMS) position error allowed, mm: the run's health verdict checks
            them when the controller tracks the move (declares it as its ``reference``).
        plant: the arm simulated, when it differs from the one the move is planned and the
            controller built for (``spec``: the designer's estimate), e.g. a heavier payload.
    """
    model = model or AnalyticModel(spec)
    plan = plan_move(spec, target, start=start, duration=duration, model=model, fit_mode=fit_mode)
    if controller is None:
        made: Any = CascadeController(spec, plan.move, mode=mode, task=plan.task, model=model,
                                      joint_path=plan.joint_reference)
        label = f"{mode}, {plan.task} task"
    else:
        made = _make(controller, spec, plan)
        label = f"{_name(controller)}, {plan.task} task"
    if hasattr(made, "tolerances"):
        made.tolerances = tuple(float(x) for x in tolerances)
    run = simulate(plant or spec, controller=made, duration=plan.move.t0 + plan.move.duration + settle,
                   initial={"q": plan.q_start, "dP": "gravity"}, label=label,
                   sample_dt=sample_dt)
    return MoveResult(plan, run, tracking_metrics(run, plan.move, label=label, model=model))


def _make(factory: ControllerFactory, spec: ManipulatorSpec, plan: MovePlan) -> Any:
    """``factory(spec, move)``, with ``joint_path=`` the plan's joint path when it takes one."""
    try:
        takes_path = "joint_path" in inspect.signature(factory).parameters
    except (TypeError, ValueError):  # a callable without a signature (a C function)
        takes_path = False
    if takes_path:
        return factory(spec, plan.move, joint_path=plan.joint_reference)
    return factory(spec, plan.move)


def _name(factory: Any) -> str:
    """A factory's name for the run's label."""
    return str(getattr(factory, "__qualname__", None) or type(factory).__qualname__)
