"""The plant in C against the Python plant it replaced (tests/reference/python_plant.py).

Both step copies of the same MuJoCo model from the same state under the same commands; the
friction/limit automaton's decisions (stick, break-away, limit stops and releases), the states
and the forces must agree to round-off on every step, on the built-in arms and the corpus of
untuned arms, under commands that make the joints stick, break away and hit their limits.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from reference.python_plant import PythonPlant

import maniplab as ml

ARMS = Path(__file__).parent / "arms"
STEPS = 1500


def _arms() -> list[str]:
    return ["erector", "crane3", *sorted(str(p) for p in ARMS.glob("*.yaml"))]


def _commands(plant: ml.Plant, steps: int, seed: int) -> np.ndarray:
    """Commands that push each joint back and forth, into its stops and through zero (so that it
    sticks): a square wave of random period per joint, at 30-100 % of the command limit (or of a
    force that moves the arm, for an unlimited source), plus pauses."""
    rng = np.random.default_rng(seed)
    limit = np.where(np.isfinite(plant.command_limit), plant.command_limit,
                     5.0 * np.abs(plant.model.dof_armature) + 200.0)
    t = np.arange(steps) * plant.dt
    out = np.empty((steps, plant.n))
    for j in range(plant.n):
        period = rng.uniform(0.2, 0.8)
        wave = np.sign(np.sin(2 * np.pi * t / period + rng.uniform(0, np.pi)))
        wave[(t % (2 * period)) > 1.5 * period] = 0.0  # pauses: the joint may stick
        out[:, j] = rng.uniform(0.3, 1.0) * limit[j] * wave
    return out


@pytest.mark.parametrize("arm", _arms(), ids=lambda a: Path(a).stem)
def test_c_plant_equals_the_python_plant(arm: str) -> None:
    plant = ml.Plant(arm)
    plant.balance_pressures()
    ref = PythonPlant(plant)
    d = plant.data
    ref.set_state(d.qpos.copy(), d.qvel.copy(), d.act.copy(), d.time)
    commands = _commands(plant, STEPS, seed=len(plant.spec.name))
    for k, u in enumerate(commands):
        plant.step(u)
        ref.step(u.tolist())
        record = plant.record
        scale = np.maximum(1.0, np.abs(ref.data.qvel))
        np.testing.assert_allclose(d.qpos, ref.data.qpos, rtol=1e-12, atol=1e-12,
                                   err_msg=f"q at step {k}")
        np.testing.assert_allclose(d.qvel / scale, ref.data.qvel / scale, rtol=0, atol=1e-11,
                                   err_msg=f"qd at step {k}")
        np.testing.assert_allclose(d.act, ref.data.act, rtol=1e-11, atol=1e-6,
                                   err_msg=f"act at step {k}")
        assert record.mode == ref.modes_at_start, f"modes at step {k}"
        assert plant.modes.tolist() == ref.modes, f"modes after step {k}"
        np.testing.assert_allclose(record.qd, ref.qd_at_start, rtol=1e-12, atol=1e-12)
        force = np.maximum(1.0, np.abs(ref.fric) + np.abs(ref.limit))
        # a LuGre joint's friction record is its bristle force, which the reference leaves out
        hybrid = np.array([j.friction.model.value != "lugre" for j in plant.spec.joints])
        np.testing.assert_allclose((np.array(record.fric) / force)[hybrid],
                                   (np.array(ref.fric) / force)[hybrid],
                                   rtol=0, atol=1e-9, err_msg=f"friction at step {k}")
        np.testing.assert_allclose(np.array(record.limit) / force, np.array(ref.limit) / force,
                                   rtol=0, atol=1e-9, err_msg=f"limit force at step {k}")


def test_the_commands_make_every_transition_somewhere() -> None:
    """The comparison above is only as good as its coverage: over the arms, joints slip, stick,
    break away, and sit on and leave both stops during the commanded motions."""
    transitions = set()
    for arm in _arms():
        plant = ml.Plant(arm)
        plant.balance_pressures()
        before = plant.modes
        for u in _commands(plant, STEPS, seed=len(plant.spec.name)):
            plant.step(u)
            after = plant.modes
            transitions.update(zip(before.tolist(), after.tolist()))
            before = after
    for pair in [(0, 1), (1, 0), (0, 2), (2, 0), (0, 3), (3, 0)]:
        assert pair in transitions, f"no transition {pair} (modes: 0 slip, 1 stick, 2-3 stops)"
