"""The exported arm alive in plain MuJoCo: the engine plugins registered by ``import mujoco``.

A fresh Python process that imports only mujoco (and numpy) loads the exported MJCF, steps it
with ``mujoco.mj_step`` and with ``mujoco.rollout`` under the same valve currents, and must
reproduce ``ml.simulate`` to 1e-9 (friction ``none``, inside the joint limits: the cases plain
MuJoCo models as maniplab's plant does)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from mujoco import rollout

import maniplab as ml

DURATION = 2.0
MIXED = Path(__file__).parent / "arms" / "mixed"

# (start pose, per joint (amplitude A, frequency Hz)) chosen to stay inside the limits
CASES = {
    "crane3": ([0.0, -0.3, 0.5], [(0.3, 0.5), (0.2, 1.0), (0.1, 0.7)]),
    "erector": ([0.0, 0.2, 0.1, 0.0, 0.0, 0.0],
                [(0.2, 0.5), (0.1, 0.8), (0.1, 1.1), (0.05, 1.3), (0.05, 0.9), (0.05, 1.7)]),
}

# runs in a fresh interpreter: nothing of maniplab imported, only what `import mujoco` registers
PLAIN_MUJOCO = r"""
import json, sys
import mujoco, numpy as np
from mujoco import rollout
args = json.load(open(sys.argv[1]))
model = mujoco.MjModel.from_xml_path(args["mjcf"])
data = mujoco.MjData(model)
data.qpos[:] = args["q0"]
data.act[:] = args["act0"]
ctrl = np.array(args["ctrl"])
q = [data.qpos.copy()]
for u in ctrl:
    data.ctrl[:] = u
    mujoco.mj_step(model, data)
    q.append(data.qpos.copy())
state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
start = mujoco.MjData(model)
start.qpos[:] = args["q0"]
start.act[:] = args["act0"]
mujoco.mj_getState(model, start, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
states, _ = rollout.rollout(model, mujoco.MjData(model), state[None], ctrl[None])
np.savez(args["out"], q=np.array(q), act=data.act.copy(), rollout=states[0])
"""


def _inputs(spec: ml.ManipulatorSpec, waves: list[tuple[float, float]]) -> dict[str, object]:
    return {j.name: ml.signals.sine(a, f) for j, (a, f) in zip(spec.joints, waves)}


@pytest.mark.parametrize(("name", "friction"), [(name, "none") for name in sorted(CASES)]
                         + [("crane3", "lugre")])
def test_plain_mujoco_and_rollout_reproduce_simulate(name: str, friction: str,
                                                     tmp_path: Path) -> None:
    """Friction none, or LuGre (its engine plugin is in the file), inside the limits."""
    q0, waves = CASES[name]
    spec = ml.builtin_spec(name).with_overrides(
        {f"joints.{j.name}.friction.model": friction for j in ml.builtin_spec(name).joints})
    plant = ml.Plant(spec)
    plant.set_state(q=q0)
    plant.balance_pressures()
    act0 = plant.data.act.copy()
    run = ml.simulate(plant, inputs=_inputs(spec, waves), duration=DURATION,
                      sample_dt=plant.dt)  # every step, as the plain script steps
    limits = np.array([j.limits for j in spec.joints])
    assert np.all((run.q > limits[:, 0] + 1e-3) & (run.q < limits[:, 1] - 1e-3))  # inside
    assert np.ptp(run.q, axis=0).min() > 1e-3  # every joint moves

    mjcf = ml.mjcf_gen.writer.write_mjcf(spec, tmp_path / f"{name}.xml")
    ctrl = np.zeros((len(run.t) - 1, plant.model.nu))  # LuGre's actuators take no control
    ctrl[:, : spec.n] = run["ctrl"][:-1]
    args = {"mjcf": str(mjcf), "q0": q0, "act0": act0.tolist(), "ctrl": ctrl.tolist(),
            "out": str(tmp_path / "plain.npz")}
    (tmp_path / "args.json").write_text(json.dumps(args))
    script = tmp_path / "plain.py"
    script.write_text(PLAIN_MUJOCO)
    subprocess.run([sys.executable, str(script), str(tmp_path / "args.json")], check=True,
                   cwd=tmp_path, timeout=300)
    plain = np.load(tmp_path / "plain.npz")
    scale = np.max(np.abs(run.q), axis=0)
    assert np.max(np.abs(plain["q"] - run.q) / scale) < 1e-9
    dP = run["dP"][-1]
    adr = plant.layout["dP"][1]
    np.testing.assert_allclose(plain["act"][adr], dP, rtol=1e-9, atol=1e-9 * np.abs(dP).max())
    if friction == "lugre":
        z = run["z"][-1]
        np.testing.assert_allclose(plain["act"][plant.layout["z"][1]], z, rtol=1e-9,
                                   atol=1e-9 * np.abs(z).max())
    nq = len(q0)
    rolled = plain["rollout"][:, 1:1 + nq]  # FULLPHYSICS: time, qpos, qvel, act, ...
    assert np.max(np.abs(rolled - run.q[1:]) / scale) < 1e-9


def _plain_run(spec: ml.ManipulatorSpec, q0: list[float], act0: np.ndarray, ctrl: np.ndarray,
               tmp_path: Path, frictionloss: bool = True) -> np.ndarray:
    """Positions of the exported MJCF stepped by plain mj_step under ``ctrl`` (one row a step)."""
    path = ml.mjcf_gen.writer.write_mjcf(spec, tmp_path / "arm.xml")
    model = mujoco.MjModel.from_xml_path(str(path))
    if not frictionloss:
        model.dof_frictionloss[:] = 0.0
    data = mujoco.MjData(model)
    data.qpos[:], data.act[:] = q0, act0
    out = [data.qpos.copy()]
    for u in ctrl:
        data.ctrl[:] = u
        mujoco.mj_step(model, data)
        out.append(data.qpos.copy())
    return np.array(out)


def test_plain_mujoco_falls_back_to_its_own_friction_and_limits(tmp_path: Path) -> None:
    """With hybrid stick/slip friction, plain MuJoCo runs the exported erector with MuJoCo's dry
    friction (frictionloss at the Coulomb level) and soft limits instead of the plant's exact
    automaton: over 5 s of valve sines it stays within 1.5 mrad (rotational) and 0.5 mm (the
    telescope) of ml.simulate, closer than without the fallback. What the docs say."""
    q0, waves = CASES["erector"]
    spec = ml.builtin_spec("erector")
    plant = ml.Plant(spec)
    plant.set_state(q=q0)
    plant.balance_pressures()
    act0 = plant.data.act.copy()
    run = ml.simulate(plant, inputs=_inputs(spec, waves), duration=5.0)
    assert (run["mode"] == 1).any()  # the plant's joints do stick
    with_fallback = np.abs(_plain_run(spec, q0, act0, run["ctrl"][:-1], tmp_path) - run.q)
    without = np.abs(_plain_run(spec, q0, act0, run["ctrl"][:-1], tmp_path, False) - run.q)
    rotational = [j for j, joint in enumerate(spec.joints) if not joint.prismatic]
    assert with_fallback[:, rotational].max() < 1.5e-3
    assert with_fallback[:, 3].max() < 0.5e-3  # q4, the telescope, m
    assert with_fallback.max(axis=0).sum() < without.max(axis=0).sum()


@pytest.mark.parametrize("arm", ["erector_pinned", MIXED / "forestry_rotator.yaml"],
                         ids=lambda a: Path(a).stem)
def test_exported_pinned_arm_starts_where_the_plant_starts(arm: str | Path) -> None:
    """Issue 33: the exported file's keyframe 0 is the plant's initial state (the chambers of a
    pinned cylinder at tank pressure), so plain ``mj_step`` and ``mujoco.rollout`` of
    ``ml.to_mjcf(spec)``, reset to it, reproduce ``ml.simulate`` from its default start to 1e-9.

    Before: the file had no keyframe and MuJoCo starts every activation at 0 (both chambers at
    0 Pa); over these 1 s of valve sines the boom of ``forestry_rotator`` was 1.3e-7 rad off
    (4.3e-6 of its motion) and the erector_pinned's q3 1.1e-7 rad (1.4e-6 of its motion)."""
    spec = ml.resolve_spec(arm)
    spec = spec.with_overrides({f"joints.{j.name}.friction.model": "none" for j in spec.joints})
    plant = ml.Plant(spec)
    waves = [(0.2, 0.5 + 0.3 * j) for j in range(spec.n)]
    run = ml.simulate(spec, inputs=_inputs(spec, waves), duration=1.0, sample_dt=plant.dt,
                      progress=False)
    limits = np.array([j.limits for j in spec.joints])
    assert np.all((run.q > limits[:, 0] + 1e-3) & (run.q < limits[:, 1] - 1e-3))  # inside
    model = mujoco.MjModel.from_xml_string(ml.to_mjcf(spec))
    assert plant.substeps == 1 and model.opt.timestep == plant.dt
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    assert np.array_equal(data.act, plant.data.act) and np.any(data.act != 0.0)
    start = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, data, start, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    ctrl = run["ctrl"][:-1]
    q = [data.qpos.copy()]
    for u in ctrl:
        data.ctrl[:] = u
        mujoco.mj_step(model, data)
        q.append(data.qpos.copy())
    scale = np.ptp(run.q, axis=0)
    assert np.max(np.abs(np.array(q) - run.q) / scale) < 1e-9
    states, _ = rollout.rollout(model, mujoco.MjData(model), start[None], ctrl[None])
    rolled = states[0][:, 1:1 + spec.n]  # FULLPHYSICS: time, qpos, ...
    assert np.max(np.abs(rolled - run.q[1:]) / scale) < 1e-9


def test_no_compiler_is_one_clear_line(tmp_path: Path) -> None:
    """Without a C compiler (and no library built yet) maniplab says so in one line and stops."""
    code = "import maniplab as ml; ml.build_model('crane3')"
    env = {"MANIPLAB_CC": "none", "MANIPLAB_CACHE": str(tmp_path), "PATH": "/usr/bin:/bin",
           "HOME": str(tmp_path)}
    proc = subprocess.run([sys.executable, "-W", "ignore", "-c", code], env=env, check=False,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode != 0
    last = proc.stderr.strip().splitlines()[-1]
    assert "need a C compiler and none was found" in last and "ModelError" in last
