"""ml.linearize against finite differences of the nonlinear plant equations (MuJoCo + eq. 4)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import maniplab as ml
from maniplab.control.linearize import linearize, operating_point
from maniplab.spec import model_of


class MujocoPlantODE:
    """ẋ = f(x, u) written out independently: MuJoCo's forward dynamics (constraints off) for the
    rigid body, slip friction and eq. (4) per joint, with the valve law of each (the paper's
    sqrt(1 - |ΔP|/Ps), or the orifice's sqrt(1 - sign(i_v) ΔP/Ps))."""

    def __init__(self, spec: ml.ManipulatorSpec, *, coulomb: bool = True) -> None:
        self.spec = spec
        self.coulomb = coulomb
        self.m = ml.build_model(spec)
        self.m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
        self.m.dof_damping[:] = 0.0  # the viscous friction is written out in friction() below
        self.d = mujoco.MjData(self.m)
        self.hyd = [i for i, j in enumerate(spec.joints) if j.actuator.type == "hydraulic"]

    def friction(self, v: float, f) -> float:
        out = f.viscous * v
        if self.coulomb and f.model.value != "none" and v != 0.0:
            out += np.sign(v) * (f.coulomb + f.static * np.exp(-((v / f.stribeck_velocity) ** 2)))
        return out

    def __call__(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        n, h = self.spec.n, len(self.hyd)
        q, qd, dP, Q = x[:n], x[n:2 * n], x[2 * n:2 * n + h], x[2 * n + h:]
        force = np.array(u, dtype=float)
        for k, i in enumerate(self.hyd):
            force[i] = self.spec.joints[i].actuator.area * dP[k]
        for i, joint in enumerate(self.spec.joints):
            force[i] -= self.friction(qd[i], joint.friction)
        self.d.qpos[:], self.d.qvel[:], self.d.qfrc_applied[:] = q, qd, force
        self.d.ctrl[:] = 0.0
        mujoco.mj_forward(self.m, self.d)
        dx = np.concatenate([qd, self.d.qacc.copy(), np.zeros(2 * h)])
        for k, i in enumerate(self.hyd):
            a = self.spec.joints[i].actuator
            dx[2 * n + k] = a.bulk_modulus / a.volume * (Q[k] - a.leakage * dP[k] - a.area * qd[i])
            drop = abs(dP[k]) if a.valve_law == "paper" else np.sign(u[i] or 1.0) * dP[k]
            flow = u[i] * a.valve_gain * np.sqrt(max(0.0, 1 - drop / a.supply_pressure))
            dx[2 * n + h + k] = (flow - Q[k]) / a.valve_tau
        return dx


def state_of(point: dict, hyd: list[int]) -> np.ndarray:
    return np.concatenate([point["q"], point["qd"], point["dP"][hyd], point["Q"][hyd]])


def fd_jacobians(f: MujocoPlantODE, x: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    scale_x = np.concatenate([np.full(2 * f.spec.n, 1e-6), np.full(len(f.hyd), 1.0),
                              np.full(len(f.hyd), 1e-9)])
    A = np.column_stack([(f(x + s * e, u) - f(x - s * e, u)) / (2 * s)
                         for s, e in zip(scale_x, np.eye(len(x)))])
    B = np.column_stack([(f(x, u + 1e-6 * e) - f(x, u - 1e-6 * e)) / 2e-6 for e in np.eye(len(u))])
    return A, B


def assert_close_columns(actual: np.ndarray, expected: np.ndarray, rtol: float) -> None:
    """Each column within rtol of its largest entry (1e-6 absolute floor for the FD noise)."""
    for k in range(expected.shape[1]):
        scale = np.abs(expected[:, k]).max()
        np.testing.assert_allclose(actual[:, k], expected[:, k], atol=rtol * scale + 1e-6,
                                   err_msg=f"column {k}")


@pytest.mark.parametrize("name", ["erector", "crane3", "planar2"])
def test_linearisation_at_rest_matches_finite_differences(name: str) -> None:
    spec = ml.builtin_spec(name)
    f = MujocoPlantODE(spec, coulomb=False)  # at rest the linear model has no Coulomb part
    q = np.array([0.6 * np.mean(j.limits or (-0.5, 1.0)) + 0.2 for j in spec.joints])
    point = operating_point(spec, q)
    x, u = state_of(point, f.hyd), point["u"]
    # the operating point is an equilibrium of the nonlinear plant
    np.testing.assert_allclose(f(x, u), 0.0, atol=1e-6)
    sys = linearize(spec, q)
    A, B = fd_jacobians(f, x, u)
    assert_close_columns(sys.A, A, 1e-6)
    assert_close_columns(sys.B, B, 1e-6)


def test_linearisation_of_a_moving_arm_with_stribeck_slope() -> None:
    spec = ml.builtin_spec("erector")
    f = MujocoPlantODE(spec)
    q = np.array([-0.2, 1.1, 0.3, 0.05, 0.1, -0.1])
    qd = np.array([0.05, -0.08, 0.01, 0.003, -0.02, 0.01])  # slipping, some inside the Stribeck dip
    point = operating_point(spec, q, qd)
    point["u"] = point["u"] * 1.3  # an input that is not the steady one: the valve term counts
    sys = linearize(spec, point)
    x = state_of(point, f.hyd)
    A, B = fd_jacobians(f, x, point["u"])
    assert_close_columns(sys.A, A, 1e-5)
    assert_close_columns(sys.B, B, 1e-6)
    # the valve's load sensitivity ∂(dQ/dt)/∂ΔP is tiny in absolute terms: compare it relatively
    n, h = spec.n, len(f.hyd)
    block = (slice(2 * n + h, None), slice(2 * n, 2 * n + h))
    assert np.abs(A[block]).max() > 0
    np.testing.assert_allclose(sys.A[block], A[block], rtol=1e-5, atol=1e-8 * np.abs(A[block]).max())


def test_names_outputs_and_python_control_analysis() -> None:
    spec = ml.builtin_spec("crane3")
    sys = linearize(spec, {"q": [0.2, -0.3, 0.5]})
    assert sys.state_labels[:4] == ["slew", "luff", "telescope", "slew_dot"]
    assert sys.state_labels[6:] == ["slew_dP", "luff_dP", "telescope_dP", "slew_Q", "luff_Q",
                                    "telescope_Q"]
    assert sys.input_labels == ["slew_iv", "luff_iv", "telescope_iv"]
    assert sys.output_labels[-3:] == ["ee_x", "ee_y", "ee_z"]
    am = ml.AnalyticModel(spec)
    np.testing.assert_allclose(sys.C[3:, :3], am.jacobian(np.array([0.2, -0.3, 0.5]))[:3])
    import control

    assert control.poles(sys).shape == (12,)
    with pytest.raises(ValueError, match="operating point"):
        linearize(spec, {"qq": [0, 0, 0]})


def test_linearisation_matches_the_simulated_plant() -> None:
    """Φ = exp(A T) against finite differences of ml.Plant's own steps over T (friction-free arm,
    so the plant's stick/slip automaton stays out of the comparison)."""
    import scipy.linalg

    from maniplab.sim import Plant

    spec = ml.builtin_spec("crane3").with_overrides(
        {f"joints.{j}.friction.model": "none" for j in ("slew", "luff", "telescope")})
    q = np.array([0.2, -0.3, 0.8])
    point = operating_point(spec, q)
    sys = linearize(spec, q)
    dt, steps = 2e-5, 50
    plant = Plant(spec, dt=dt)
    n = spec.n

    def flow(x: np.ndarray) -> np.ndarray:
        plant.set_state(q=x[:n], qd=x[n:2 * n], dP=x[2 * n:3 * n], Q=x[3 * n:], t=0.0)
        for _ in range(steps):
            plant.step(point["u"])
        s = plant.state()
        return np.concatenate([s.q, s.qd, s.dP, s.Q])

    x0 = np.concatenate([point["q"], point["qd"], point["dP"], point["Q"]])
    scale = np.concatenate([np.full(n, 1e-6), np.full(n, 1e-6), np.full(n, 1e2), np.full(n, 1e-9)])
    Phi = np.column_stack([(flow(x0 + s * e) - flow(x0 - s * e)) / (2 * s)
                           for s, e in zip(scale, np.eye(len(x0)))])
    expected = scipy.linalg.expm(sys.A * dt * steps)
    # compare in scaled units (each state by its perturbation size); the residual, 0.1 % of the
    # largest entries, is the plant's own discretisation error (0.3 % at dt = 1e-4 s)
    S = np.diag(scale)
    np.testing.assert_allclose(np.linalg.solve(S, Phi @ S), np.linalg.solve(S, expected @ S),
                               atol=3e-3)


def test_a_pinned_cylinder_arm_linearises_as_mujoco_computes_it() -> None:
    """On the PATU-like crane with two pinned cylinders (and a lumped slew), the linear model's A
    and B equal central differences of MuJoCo's own evaluation of the plant (qacc through the
    cylinders' tendons, act_dot from the engine plugins) at a held pose, to 1e-5 per column."""
    spec = ml.builtin_spec("patu655")
    spec = spec.with_overrides({f"joints.{j.name}.friction": {"model": "none"}
                                for j in spec.joints})
    m = ml.build_model(spec)
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    d = mujoco.MjData(m)
    q = np.array([0.3, -0.4, 1.0])
    point = operating_point(spec, q)
    sys = linearize(spec, point)
    n = spec.n
    # the linear model's actuator states, each at its address in MuJoCo's act
    where = {f"{j.name}_{name}": int(m.actuator_actadr[i]) + k
             for i, j in enumerate(spec.joints) for k, name in enumerate(model_of(j).states)}
    labels = sys.state_labels[2 * n:]
    adr = [where[label] for label in labels]

    def f(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        d.qpos[:], d.qvel[:], d.ctrl[:] = x[:n], x[n:2 * n], u
        d.act[adr] = x[2 * n:]
        mujoco.mj_forward(m, d)
        return np.concatenate([x[n:2 * n], d.qacc, d.act_dot[adr]])

    x = np.concatenate([point["q"], point["qd"],
                        [point[label.split("_", 1)[1]][spec.joint_index(label.split("_", 1)[0])]
                         for label in labels]])
    u = point["u"]
    assert np.abs(f(x, u)[n:2 * n]).max() < 1e-6  # a held pose: no acceleration
    scale = np.concatenate([np.full(2 * n, 1e-6), np.maximum(np.abs(x[2 * n:]), 1.0) * 1e-6])
    A = np.column_stack([(f(x + s * e, u) - f(x - s * e, u)) / (2 * s)
                         for s, e in zip(scale, np.eye(len(x)))])
    B = np.column_stack([(f(x, u + 1e-6 * e) - f(x, u - 1e-6 * e)) / 2e-6 for e in np.eye(n)])
    assert_close_columns(sys.A, A, 1e-5)
    assert_close_columns(sys.B, B, 1e-5)
