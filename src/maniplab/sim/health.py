"""The health verdict of a run, computed from its signals: what went wrong, on which joint, and
what to change.

Every run has one (:attr:`maniplab.Run.health`), open or closed loop, also when loaded from a
file. The checks:

- **saturation** (closed loop: a run with a controller): a joint's command at its limit for
  more than SATURATION of the run: the actuator cannot give what the controller asked (a valve's
  flow, a motor's voltage); in open loop the command is the user's own input;
- **bounds**: a state beyond a bound its actuator declares (a pressure beyond the supply: a
  warning, the load drives the oil; beyond a relief's setting: a failure, the run is wrong);
- **pinned**: a joint held on a limit for more than PINNED of the run while the run commanded it;
- **still**: a joint commanded with more than STILL_COMMAND of its range for STILL_TIME s that
  did not move at all (a frozen actuator, or a load it cannot lift);
- **tracking**: in a run with a reference (its position ``p_ref`` and ``meta["reference"]``:
  the move's window and tolerances, written by a controller that declares a reference): the
  end-effector's final error, and its RMS error over the move, within the tolerances (mm): a
  run that ends far from its target is never "ok";
- **impact**: a joint that reaches one of its limits moving with more kinetic energy than its
  end stops may take (``joints[].stop_energy``, default IMPACT_ENERGY): ½ M_jj(q) v², M the arm's
  mass matrix at the pose (MuJoCo's, payload included) and v the last recorded speed before the
  stop; the finding names the joint, the speed and the energy;
- **burst**: in a run with hose bursts (:mod:`~maniplab.sim.bursts`), a load that moved more
  than 1 mm after its line burst: a failure naming the joint, the line and the distance;
- **lowering**: a sustained oscillation of a holding chamber's pressure while a load is lowered
  through its counterbalance valve (:mod:`~maniplab.sim.lowering`): the frequency, the swing and
  the pilot ratio to change;
- **diverging**: in a closed-loop run (one with the controller's reference ``x_d`` and task
  error ``e_x``), once the reference has come to rest: the error over the second half of that
  rest more than DIVERGING times the first half's, and above 1 mm: the loop is unstable.

A finding is a warning or a failure; the verdict is "ok", "warnings" or "failed".
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np

from maniplab.friction import FrictionMode
from maniplab.sim import bursts, lowering
from maniplab.sim.findings import Finding, Severity
from maniplab.spec import Joint, model_of
from maniplab.spec.actuator import UnresolvedActuator

if TYPE_CHECKING:
    from maniplab.actuators import ActuatorPlugin
    from maniplab.sim.run import Run

SATURATION = 0.05
"""Share of the run at the command limit beyond which a joint is reported saturated."""

PINNED = 0.1
"""Share of the run on a limit beyond which a commanded joint is reported pinned."""

STILL_COMMAND, STILL_TIME = 0.2, 0.2
"""A joint commanded beyond this share of its range for this long, s, must move."""

DIVERGING = 2.0
"""A closed-loop error growing by this factor over the reference's rest diverges."""

REST = 0.2
"""The least time, s, the reference must rest for the divergence check."""

IMPACT_ENERGY = 100.0
"""J: the kinetic energy at a limit beyond which an impact is reported, unless the joint's
``stop_energy`` says otherwise."""


@dataclasses.dataclass(frozen=True)
class Health:
    """A run's health verdict: its findings, worst first."""

    findings: tuple[Finding, ...]

    @property
    def verdict(self) -> str:
        """"ok", "warnings" or "failed"."""
        if any(f.severity is Severity.FAILURE for f in self.findings):
            return "failed"
        return "warnings" if self.findings else "ok"

    def lines(self) -> list[str]:
        """One line per finding, with its severity."""
        return [f"{f.severity.value}: {f.line()}" for f in self.findings]

    def summary(self) -> str:
        """The verdict and the worst finding, one line."""
        return self.verdict if not self.findings else f"{self.verdict}: {self.findings[0].line()}"

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly: verdict and findings."""
        return {"verdict": self.verdict,
                "findings": [{**dataclasses.asdict(f), "severity": f.severity.value}
                             for f in self.findings]}


def assess(run: Run) -> Health:
    """The health of ``run`` from its signals (see the module's checks)."""
    t = np.asarray(run.t, dtype=float)
    if len(t) < 2:
        return Health(())
    hold = np.append(np.diff(t), 0.0)  # each sample's command holds until the next
    span = float(t[-1] - t[0])
    findings = [*_saturation(run, hold, span), *_bounds(run), *_pinned(run, hold, span),
                *_still(run, hold), *_impacts(run), *_diverging(run), *_tracking(run),
                *bursts.drop_findings(run), *lowering.findings(run)]
    findings.sort(key=lambda f: f.severity is not Severity.FAILURE)
    return Health(tuple(findings))


def _model(joint: Joint) -> ActuatorPlugin | None:
    """The joint's actuator model; None for a stored run's plugin that is not loaded (its limits
    and bounds are then unknown, and not checked)."""
    return None if isinstance(joint.actuator, UnresolvedActuator) else model_of(joint)


def _limits(run: Run) -> np.ndarray:
    return np.array([np.inf if (model := _model(j)) is None or model.command_limit is None
                     else model.command_limit for j in run.spec.joints])


def _saturation(run: Run, hold: np.ndarray, span: float) -> list[Finding]:
    if "ctrl" not in run or not (run.meta or {}).get("controller"):
        return []
    ctrl = np.abs(np.asarray(run["ctrl"]))
    at = ctrl >= _limits(run) * (1.0 - 1e-9)
    out = []
    for j, name in enumerate(run.spec.joint_names):
        seconds = float(hold[at[:, j]].sum())
        if seconds > SATURATION * span:
            out.append(Finding(
                Severity.WARNING, "saturation", name,
                f"command at its limit for {seconds:.3g} s ({seconds / span:.0%} of the run)",
                "the actuator cannot deliver what was asked: a longer move duration, lower "
                "gains, or a larger actuator (valve_gain, current_limit)"))
    return out


def _bounds(run: Run) -> list[Finding]:
    out = []
    for j, joint in enumerate(run.spec.joints):
        seen = set()
        model = _model(joint)
        for bound in sorted(model.bounds() if model else [], key=lambda b: -b.limit):
            if bound.state not in run or bound.state in seen:
                continue
            values = np.abs(np.asarray(run[bound.state])[:, j])
            peak = float(np.nanmax(values)) if np.isfinite(values).any() else 0.0
            if peak > bound.limit * (1.0 + 1e-6):
                seen.add(bound.state)
                out.append(Finding(
                    Severity.FAILURE if bound.hard else Severity.WARNING, "bounds", joint.name,
                    f"|{bound.state}| reached {peak:.4g}, beyond the {bound.name} {bound.limit:.4g}",
                    "the model lets it through; the run is not to be trusted" if bound.hard else
                    "the load drives the actuator: a relief valve (relief_pressure) caps it, a "
                    "slower or gentler move avoids it"))
    return out


def _pinned(run: Run, hold: np.ndarray, span: float) -> list[Finding]:
    if "mode" not in run or "ctrl" not in run:
        return []
    mode, ctrl = np.asarray(run["mode"]), np.asarray(run["ctrl"])
    on = (mode == FrictionMode.AT_LOWER.value) | (mode == FrictionMode.AT_UPPER.value)
    out = []
    for j, name in enumerate(run.spec.joint_names):
        pushed = on[:, j] & (ctrl[:, j] != 0.0)
        seconds = float(hold[pushed].sum())
        if seconds > PINNED * span:
            out.append(Finding(
                Severity.WARNING, "pinned", name,
                f"held on a joint limit for {seconds:.3g} s while commanded",
                "the motion asks for more range: another target or start, or wider limits"))
    return out


def _still(run: Run, hold: np.ndarray) -> list[Finding]:
    if "ctrl" not in run:
        return []
    ctrl, q = np.abs(np.asarray(run["ctrl"])), np.asarray(run.q)
    pushed = ctrl >= STILL_COMMAND * _limits(run)
    out = []
    for j, name in enumerate(run.spec.joint_names):
        if float(hold[pushed[:, j]].sum()) < STILL_TIME:
            continue
        if float(np.ptp(q[:, j])) == 0.0 and not _on_limit(run, j):
            out.append(Finding(
                Severity.FAILURE, "still", name,
                f"commanded with {STILL_COMMAND:.0%} of its range or more for "
                f"{hold[pushed[:, j]].sum():.3g} s, it did not move at all",
                "check the actuator's parameters against the load (area, supply pressure, "
                "limit) and the joint's friction"))
    return out


def impacts(run: Run) -> list[tuple[str, float, float, float]]:
    """Every arrival of a joint at one of its limits while moving: (joint, time s, speed rad/s
    or m/s, kinetic energy ½ M_jj v² J), the speed the last recorded before the stop."""
    if "mode" not in run:
        return []
    mode, qd = np.asarray(run["mode"]), np.asarray(run.qd)
    on = (mode == FrictionMode.AT_LOWER.value) | (mode == FrictionMode.AT_UPPER.value)
    # the step that reaches the stop zeroes the speed the next sample records, a sample before
    # the mode says so: the speed is the last non-zero one of the few samples before
    arrivals = []
    for a, j in np.argwhere(on[1:] & ~on[:-1]) + [1, 0]:
        moving = np.flatnonzero(qd[max(0, a - 3):a, j] != 0.0)
        if moving.size:
            arrivals.append((a, j, float(qd[max(0, a - 3) + moving[-1], j])))
    if not arrivals:
        return []
    import mujoco

    from maniplab.errors import ManiplabError
    from maniplab.mjcf_gen import build_model

    try:
        model = build_model(run.spec)
    except ManiplabError:  # a stored run's plugin that is not loaded: no mass matrix
        return []
    data = mujoco.MjData(model)
    out = []
    for a, j, v in arrivals:
        data.qpos[:] = np.asarray(run.q)[a]
        mujoco.mj_forward(model, data)
        full = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, full)
        out.append((run.spec.joint_names[j], float(run.t[a]), abs(v),
                    0.5 * float(full[j, j]) * v * v))
    return out


def _impacts(run: Run) -> list[Finding]:
    worst: dict[str, tuple[float, float, float]] = {}
    for joint, t, speed, energy in impacts(run):
        if energy > worst.get(joint, (0.0, 0.0, -1.0))[2]:
            worst[joint] = (t, speed, energy)
    out = []
    for joint, (t, speed, energy) in worst.items():
        spec_joint = run.spec.joint(joint)
        allowed = spec_joint.stop_energy or IMPACT_ENERGY
        if energy > allowed:
            unit = "m/s" if spec_joint.prismatic else "rad/s"
            out.append(Finding(
                Severity.WARNING, "impact", joint,
                f"hit its limit at t = {t:.3g} s at {speed:.3g} {unit} with {energy:.3g} J, "
                f"more than the {allowed:.3g} J its stops may take",
                "slow it before the stop (the move or the command), give its cylinder end "
                "cushions, or set the stops' rating (joints[].stop_energy)"))
    return out


def _on_limit(run: Run, j: int) -> bool:
    if "mode" not in run:
        return False
    mode = np.asarray(run["mode"])[:, j]
    return bool(np.any((mode == FrictionMode.AT_LOWER.value) | (mode == FrictionMode.AT_UPPER.value)))


def _diverging(run: Run) -> list[Finding]:
    if "e_x" not in run or "x_d" not in run:
        return []
    reference = np.nan_to_num(np.asarray(run["x_d"]))
    moving = np.flatnonzero(np.any(np.abs(reference - reference[-1]) > 1e-12, axis=1))
    start = int(moving[-1]) + 1 if moving.size else 0
    t = np.asarray(run.t)
    if t[-1] - t[min(start, len(t) - 1)] < REST:
        return []
    error = np.linalg.norm(np.nan_to_num(np.asarray(run["e_x"])[start:, :3]), axis=1)
    half = len(error) // 2
    last, before = float(np.max(error[half:])), float(np.max(error[:half]))
    if last > 1e-3 and last > DIVERGING * before:
        return [Finding(
            Severity.FAILURE, "diverging", None,
            f"the tracking error grows ({1e3 * before:.3g} mm, then {1e3 * last:.3g} mm)",
            _gains(run, "the loop is unstable: lower")
            + " or the pressure bandwidth (control.pressure.bandwidth), or run 'maniplab tune'"
            if _mode(run) != "pid" else _gains(run, "the loop is unstable: lower"))]
    return []


def tracking_errors(run: Run) -> tuple[float, float] | None:
    """(final, RMS over the move) position error of the end-effector (of the suspension point,
    ``p_suspension``, on an arm whose tool hangs on passive joints) against the run's reference
    ``p_ref``, mm; None for a run without a reference."""
    reference = (run.meta or {}).get("reference")
    tracked = "p_suspension" if "p_suspension" in run else "ee_pos"
    if not reference or "p_ref" not in run or tracked not in run:
        return None
    t = np.asarray(run.t)
    error = 1e3 * np.linalg.norm(np.asarray(run[tracked]) - np.asarray(run["p_ref"]), axis=1)
    inside = (t >= reference["t0"] - 1e-9) & (t <= reference["t1"] + 1e-9)
    rms = float(np.sqrt(np.mean(error[inside] ** 2))) if inside.any() else 0.0
    return float(error[-1]), rms


def _tracking(run: Run) -> list[Finding]:
    errors = tracking_errors(run)
    if errors is None:
        return []
    final, rms = errors
    reference = run.meta["reference"]
    misses = []
    if not final <= reference["final_mm"]:
        misses.append(f"final position error {final:.3g} mm > {reference['final_mm']:g} mm")
    if not rms <= reference["rms_mm"]:
        misses.append(f"RMS error over the move {rms:.3g} mm > {reference['rms_mm']:g} mm")
    if not misses:
        return []
    return [Finding(
        Severity.FAILURE, "tracking", None, "; ".join(misses),
        _gains(run, "the controller does not follow its reference: raise")
        + " or check its model of the arm (payload, friction)")]


def _mode(run: Run) -> str | None:
    """The maniplab controller's mode ("cascade", "pid"), None for another controller."""
    control = (run.meta or {}).get("control")
    return control.get("mode") if isinstance(control, dict) else None


def _gains(run: Run, verb: str) -> str:
    """``verb`` the gains of the run's controller, named as its settings are."""
    mode = _mode(run)
    if mode == "pid":
        return f"{verb} the baseline's joint gains (control.pid_only.kp, .ki)"
    if mode == "cascade":
        return f"{verb} the outer gains (control.position, control.orientation)"
    return f"{verb} your controller's gains"
