"""A point-to-point move, planned, run under the controller and judged: what ``maniplab control``
does, as one function."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from maniplab.control.cascade import CascadeController
from maniplab.control.metrics import TrackingMetrics, tracking_metrics
from maniplab.control.point_to_point import MovePlan, plan_move
from maniplab.model import AnalyticModel
from maniplab.sim.health import Health
from maniplab.sim.run import Run
from maniplab.sim.simulate import simulate
from maniplab.spec import ManipulatorSpec

TOLERANCES = (2.0, 5.0)
"""The default tolerances of a move, mm: the final position error and the RMS error."""


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
        if not misses and health.verdict != "failed":
            return None
        what = ("the move missed its tolerances (" + ", ".join(misses) + ")" if misses
                else "the run failed its health check")
        if health.findings:
            return f"{what}: {health.findings[0].line()}"
        return (f"{what}: no actuator reached a limit; raise the outer gains (control.position) "
                "or check the controller's model of the arm (payload, friction)")


def run_move(spec: ManipulatorSpec, target: Sequence[float], *, start: Sequence[float] | None,
             duration: float, mode: str = "cascade", fit_mode: str = "stretch",
             settle: float = 1.0, model: AnalyticModel | None = None,
             sample_dt: float | None = None) -> MoveResult:
    """Plan a move to ``target`` (:func:`~maniplab.control.point_to_point.plan_move`), run it
    from rest with the actuators holding the arm against gravity, and measure it.

    Args:
        spec: the arm; its ``control:`` section, completed from the arm, sets the controller.
        target, start, duration, fit_mode: as for ``plan_move``.
        mode: "cascade" or "pid" (the PID-only baseline).
        settle: time simulated after the move, s.
        model: the arm's analytic model.
        sample_dt: the run's recording interval, s (default: every step, as ``simulate``).
    """
    model = model or AnalyticModel(spec)
    plan = plan_move(spec, target, start=start, duration=duration, model=model, fit_mode=fit_mode)
    controller = CascadeController(spec, plan.move, mode=mode, task=plan.task, model=model)
    label = f"{mode}, {plan.task} task"
    run = simulate(spec, controller=controller, duration=plan.move.t0 + plan.move.duration + settle,
                   initial={"q": plan.q_start, "dP": "gravity"}, label=label,
                   sample_dt=sample_dt)
    return MoveResult(plan, run, tracking_metrics(run, plan.move, label=label, model=model))
