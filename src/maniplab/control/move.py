"""A point-to-point move, planned, run under the controller and judged: what ``maniplab control``
does, as one function."""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from maniplab.control.cascade import CascadeController
from maniplab.control.errors import ControlError
from maniplab.control.interface import TOLERANCES
from maniplab.control.metrics import TrackingMetrics, tracking_metrics
from maniplab.control.point_to_point import MovePlan, plan_move
from maniplab.control.shaping import ShapedMove, zvd
from maniplab.control.suspended import (
    HangingController,
    Sway,
    chain,
    hanging,
    hanging_weight,
    passive_joints,
    pendulum_frequency,
    suspended,
    sway,
)
from maniplab.control.trajectory import MinJerkMove
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
        sway: each passive joint's sway after the move (none without passive joints).
    """

    plan: MovePlan
    run: Run
    metrics: TrackingMetrics
    sway: tuple[Sway, ...] = ()

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
        goal = np.asarray(self.plan.q_goal)  # the actuated joints' (a hanging tool's are free)
        q = np.asarray(self.run.q)[-1][:len(goal)]
        joints = self.run.spec.joints[:len(goal)]
        lower = np.array([j.limits[0] if j.limits else -np.pi for j in joints])
        upper = np.array([j.limits[1] if j.limits else np.pi for j in joints])
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
             plant: ManipulatorSpec | None = None, sway_damping: bool = False) -> MoveResult:
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
        sway_damping: shape the move so that the tool hanging on the arm's passive joints is
            left without residual sway (a ZVD input shaper at its pendulum frequency,
            :mod:`~maniplab.control.shaping`; the move is longer by one period).

    On an arm whose tool hangs on passive joints (the last joints, ``type: passive``) the target
    is the suspension point's: the move is planned and the controller built on the actuated
    chain with the hanging mass at that point (:func:`~maniplab.control.suspended.suspended`),
    the plant simulates the whole arm from rest with the tool hanging (the passive joints'
    ``start`` values are replaced by that pose), and the result reports each passive joint's
    sway after the move.
    """
    hangs = bool(passive_joints(spec))  # a tool hangs from the arm's actuated chain
    arm = suspended(spec)  # that chain, or the arm itself
    model = model if model is not None and model.spec == arm else AnalyticModel(arm)
    actuated = None if start is None else list(start)[:arm.n] if hangs else start
    plan = plan_move(arm, target, start=actuated, duration=duration, model=model,
                     fit_mode=fit_mode)
    if sway_damping:
        plan = _shaped(plan, spec)
    if controller is None and not hangs:
        made: Any = CascadeController(arm, plan.move, mode=mode, task=plan.task, model=model,
                                      joint_path=plan.joint_reference)
        label = f"{mode}, {plan.task} task"
    elif controller is None:  # the chain's inertia, the hanging tool's weight as a force
        made = CascadeController(chain(spec), plan.move, mode=mode, task=plan.task,
                                 joint_path=plan.joint_reference, weight=hanging_weight(spec))
        label = f"{mode}, {plan.task} task"
    else:
        made = _make(controller, arm, plan)
        label = f"{_name(controller)}, {plan.task} task"
    if hangs:
        made = HangingController(made, spec)
    if hasattr(made, "tolerances"):
        made.tolerances = tuple(float(x) for x in tolerances)
    q0 = hanging(spec, np.concatenate([plan.q_start, np.zeros(spec.n - arm.n)]))
    end = plan.move.t0 + plan.move.duration
    run = simulate(plant or spec, controller=made, duration=end + settle,
                   initial={"q": q0, "dP": "gravity"}, label=label, sample_dt=sample_dt)
    return MoveResult(plan, run, tracking_metrics(run, plan.move, label=label, model=model),
                      tuple(sway(run, end)))


def _shaped(plan: MovePlan, spec: ManipulatorSpec) -> MovePlan:
    """The plan with its move shaped by a ZVD shaper (:mod:`~maniplab.control.shaping`) at the
    hanging tool's pendulum frequency (the mean of its frequencies at the start and the goal)."""
    n = spec.n - len(passive_joints(spec))
    if n == spec.n:
        raise ControlError(f"{spec.name} has no passive joints: there is no sway to damp")
    tail = np.zeros(spec.n - n)
    frequency = 0.5 * sum(pendulum_frequency(spec, hanging(spec, np.concatenate([q, tail])))
                          for q in (plan.q_start, plan.q_goal))
    move = plan.move
    assert isinstance(move, MinJerkMove), "a plan's move is shaped once"
    return dataclasses.replace(plan, move=ShapedMove(move, zvd(frequency)))


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
