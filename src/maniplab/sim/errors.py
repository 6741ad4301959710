"""Errors of simulation runs (all derive from :class:`maniplab.ManiplabError`)."""

from __future__ import annotations

from maniplab.errors import ManiplabError


class SimulationError(ManiplabError):
    """A simulation cannot be set up or did not finish."""


class InputError(SimulationError, ValueError):
    """Bad arguments to a simulation: unknown joint, wrong shape, non-finite command or state."""


class InstabilityError(SimulationError):
    """The integration went unstable (NaN, MuJoCo warning, pressure far beyond supply).

    Attributes:
        time: simulation time at which it was detected, s.
        joint: the joint's name, or None when not attributable to one joint.
    """

    def __init__(self, problem: str, *, time: float, joint: str | None, dt: float,
                 works: float | None = None, resolved: bool = False) -> None:
        """``works``: a step known to work; ``resolved``: the step already resolves the arm's
        dynamics, so the problem is the model's (its text says what to change), not the step's."""
        self.time = time
        self.joint = joint
        where = f" on joint {joint}" if joint else ""
        if resolved:
            advice = ""
        elif works is None:
            advice = f"; try a smaller step, e.g. dt={dt / 4:g} (it was {dt:g})"
        else:
            advice = f"; use dt <= {works:.3g} s (it was {dt:g})"
        super().__init__(f"simulation unstable at t = {time:.6g} s{where}: {problem}{advice}")


class PluginError(SimulationError):
    """An actuator plugin raised inside a step (the original exception is the ``__cause__``)."""
