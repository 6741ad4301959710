"""Sections on a pump that runs short: post-compensated (flow-sharing, LUDV) sections all slow in
the same proportion, pre-compensated ones give the lightest load its flow (issue 34)."""

from __future__ import annotations

import numpy as np
import pytest

import maniplab as ml
from maniplab.errors import SpecError
from maniplab.sim.energy import LOSSES, energy_report
from maniplab.spec import model_of

Q_MAX = 4.0e-4  # m³/s: the pump, short of the 7.1e-4 the two sections ask at 15 bar


def _short_pump(sharing: bool) -> ml.ManipulatorSpec:
    """patu655 on a 15 bar load-sensing pump of Q_MAX, its lift and tilt sections
    post-compensated (flow sharing) or pre-compensated at 12 bar."""
    data = ml.resolve_spec("patu655").to_dict()
    data["supply"] = {"pressure": 8.0e6, "max_flow": Q_MAX, "ls_margin": 15.0e5}
    for joint in data["joints"][1:]:
        valve = joint["actuator"]["valve"]
        valve.update({"flow_sharing": True} if sharing else {"compensator_margin": 12.0e5})
    return ml.ManipulatorSpec.from_dict(data)


def _cap_flows(spec: ml.ManipulatorSpec, run: ml.Run) -> dict[str, float]:
    """The mean flow into each cylinder's cap side over 0.35-0.55 s, by continuity from the
    run's signals (the piston's, the oil compressed, the leakage), m³/s."""
    window = (run.t > 0.35) & (run.t < 0.55)
    flows = {}
    for name in ("lift", "tilt"):
        k, joint = spec.joint_index(name), spec.joint(name)
        act, geometry = joint.actuator, model_of(joint).geometry
        q, qd, pa, pb = run.q[:, k], run.qd[:, k], run["pA"][:, k], run["pB"][:, k]
        volume = act.chamber_dead_volumes[0] + act.cylinder.cap_area * (
            geometry.length(q) - act.cylinder.min_length)
        flow = act.cylinder.cap_area * geometry.arm(q) * qd \
            + volume / act.bulk_modulus * np.gradient(pa, run.t) + act.leakage * (pa - pb)
        flows[name] = float(flow[window].mean())
    return flows


@pytest.mark.parametrize("sharing", [True, False], ids=["flow-sharing", "pre-compensated"])
def test_two_sections_on_a_short_pump_share_its_flow_as_their_kind_does(sharing: bool) -> None:
    """Lift at half opening, tilt at 0.8: together they ask 7.1e-4 m³/s of a 4e-4 pump. Both
    kinds take the pump's whole flow (1e-4). Flow-sharing sections get it in proportion to what
    they ask, K_A x (closed form; measured to 3e-7); pre-compensated ones give the lighter load
    (the tilt, 12 bar against the lift's 32) its own compensated flow, K_A x g(12 bar), and the
    heavier the rest (within the compensator's regulation band: 0.24 % less). The energy balance
    closes and every loss is positive."""
    spec = _short_pump(sharing)
    limits = {j.name: j.actuator.valve.current_limit for j in spec.joints[1:]}
    openings = {"lift": 0.5, "tilt": 0.8}
    run = ml.simulate(spec, duration=0.6, initial={"q": [0.0, -0.3, 1.2], "dP": "gravity"},
                      inputs={n: ml.signals.step(x * limits[n], 0.1) for n, x in openings.items()},
                      sample_dt=1e-3)
    flows = _cap_flows(spec, run)
    assert flows["lift"] + flows["tilt"] == pytest.approx(Q_MAX, rel=1e-4)
    gains = {n: spec.joint(n).actuator.valve.gain_a for n in openings}
    asked = {n: gains[n] * openings[n] for n in openings}
    if sharing:
        assert flows["lift"] / flows["tilt"] == pytest.approx(asked["lift"] / asked["tilt"],
                                                              rel=1e-4)
    else:
        band = 0.05 * spec.joint("tilt").actuator.valve.edge_drop
        own = asked["tilt"] * 12.0e5 / (12.0e5**2 + band**2) ** 0.25
        assert flows["tilt"] == pytest.approx(own, rel=1e-2)  # the compensator's band: 0.24 %
        assert flows["lift"] < 0.6 * asked["lift"] * 15.0e5**0.5
    report = energy_report(run)
    assert abs(report.residual) < 1e-9 * report.pump
    for loss in LOSSES:  # the ideal anti-cavitation valve's: the step's error, ~0
        least = -1e-3 if loss == "anticavitation" else -1e-9
        assert report.total(loss) >= least * report.pump, loss


def test_flow_sharing_and_a_compensator_margin_are_one_line() -> None:
    data = _short_pump(True).to_dict()
    data["joints"][1]["actuator"]["valve"]["compensator_margin"] = 12.0e5
    with pytest.raises(SpecError, match=r"joints\[1\]|lift") as err:
        ml.ManipulatorSpec.from_dict(data)
    assert "flow_sharing" in str(err.value) and "\n" not in str(err.value)
