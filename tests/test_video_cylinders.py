"""Pinned hydraulic cylinders in the offscreen videos: a teal barrel from the parent pin and a
chrome rod from the child pin, found in the rendered pixels where a pinhole projection of the
pins puts them, the rod sliding out of the barrel as the joint strokes the cylinder; an arm
without pinned cylinders has no teal at all; a ghost's cylinders are in its run colour.

The reference is independent of the drawing code: the pins are the MuJoCo sites the tendon runs
between, and a point's pixel follows from the fixed camera's pose (``data.cam_xpos``,
``data.cam_xmat``: it looks along its -z, x right, y up) and vertical field of view
(``model.cam_fovy``), as MuJoCo documents its cameras. Frames are small (320x240, no
antialiasing), runs a few frames long.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np
import pytest

import maniplab as ml
from maniplab.sim.run import Run
from maniplab.viz import palette
from maniplab.viz.arm import ArmView
from maniplab.viz.camera import Framing
from maniplab.viz.cylinders import BARREL, ROD
from maniplab.viz.look import Look
from maniplab.viz.render import SingleRun

W, H = 320, 240
ARMS = Path(__file__).parent / "arms"
SIDE = np.array([0.25, -1.0, 0.15])  # from the side of the arm's plane (its pins are at y = 0)


pytestmark = pytest.mark.usefixtures("offscreen_gl")


def teal(pixels: np.ndarray) -> np.ndarray:
    """Where ``pixels`` (uint8, shape (..., 3)) are the barrel's dark teal in any light: green
    and blue alike and well above red. No link, joint state, floor or sky colour is."""
    r, g, b = (pixels[..., c].astype(int) for c in range(3))
    return (g > r + 30) & (b > r + 30) & (np.abs(g - b) < 30)


def chrome(pixels: np.ndarray) -> np.ndarray:
    """Where ``pixels`` are the rod's light neutral grey (the sky is bluer, the floor darker)."""
    p = pixels.astype(int)
    return (p.max(axis=-1) - p.min(axis=-1) <= 15) & (p.mean(axis=-1) >= 100)


def ramp(spec: ml.ManipulatorSpec, frames: int, lo: float = 0.1, hi: float = 0.9) -> Run:
    """A run through ``frames`` frames at 1 fps, every limited joint going from ``lo`` to ``hi``
    of its range (slew at 0: the arm's plane is the x-z plane)."""
    t = np.arange(frames, dtype=float)
    q = np.zeros((frames, spec.n))
    for j, joint in enumerate(spec.joints):
        if joint.limits is not None and joint.name != "slew":
            low, high = joint.limits
            q[:, j] = low + (lo + (hi - lo) * t / max(frames - 1, 1)) * (high - low)
    return Run(t, {"q": q, "qd": np.zeros_like(q), "mode": np.zeros(q.shape, dtype=np.int8)},
               spec)


class Shot:
    """One rendered frame with what the reference needs: the image (H, W, 3), the cylinder's
    pins (m, shape (3,) each) and the camera's pose and field of view."""

    def __init__(self, image: np.ndarray, base: np.ndarray, tip: np.ndarray,
                 data: mujoco.MjData, model: mujoco.MjModel, camera: int) -> None:
        self.image, self.base, self.tip = image.copy(), base.copy(), tip.copy()
        self.eye = data.cam_xpos[camera].copy()
        self.rotation = data.cam_xmat[camera].reshape(3, 3).copy()
        self.focal = 0.5 * H / math.tan(math.radians(float(model.cam_fovy[camera])) / 2.0)

    def pixel(self, point: np.ndarray) -> tuple[int, int]:
        """Column and row of the pixel where ``point`` (m, shape (3,)) is seen."""
        x, y, z = self.rotation.T @ (np.asarray(point) - self.eye)
        return int(0.5 * W + self.focal * x / -z), int(0.5 * H - self.focal * y / -z)

    def looks(self, point: np.ndarray, colour: Callable[[np.ndarray], np.ndarray]) -> bool:
        """Whether a pixel within one of where ``point`` is seen has ``colour`` (:func:`teal`,
        :func:`chrome`)."""
        col, row = self.pixel(point)
        return bool(colour(self.image[max(row - 1, 0):row + 2, max(col - 1, 0):col + 2]).any())

    @property
    def length(self) -> float:
        """Pin to pin, m."""
        return float(np.linalg.norm(self.tip - self.base))

    def at(self, s: float) -> np.ndarray:
        """The point ``s`` m from the child pin towards the parent pin."""
        return self.tip + s * (self.base - self.tip) / self.length

    def metres_per_pixel(self) -> float:
        """Size of a pixel at the cylinder's middle, m."""
        depth = -(self.rotation.T @ (0.5 * (self.base + self.tip) - self.eye))[2]
        return depth / self.focal


def shots(spec: ml.ManipulatorSpec, joint: str, frames: int = 2) -> list[Shot]:
    """Frames of ``ramp(spec)`` seen from :data:`SIDE`, framed on ``joint``'s cylinder."""
    run = ramp(spec, frames)
    arm = ArmView(spec)
    pins = []
    for q in run.q:
        arm.pose(q)
        pins += [arm.data.site(f"{joint}/cylinder_{end}").xpos.copy() for end in ("base", "rod")]
    points = np.vstack([np.array(pins) - 0.3, np.array(pins) + 0.3])
    framing = Framing(points, SIDE / np.linalg.norm(SIDE), np.array([0.0, 0.0, 1.0]))
    single = SingleRun(run, W, H, 1.0, Look(framing, False, False, False, False, None))
    view = single.view
    camera, arm = view.cameras[0].fixedcamid, view.arms[0]
    taken = []
    for k in range(len(single.times)):
        image = view.frame(k)
        base, tip = (arm.data.site(f"{joint}/cylinder_{end}").xpos for end in ("base", "rod"))
        taken.append(Shot(image, base, tip, arm.data, arm.model, camera))
    view.close()
    return taken


def barrel_end(shot: Shot) -> float:
    """How far from the child pin the first teal is seen along the pin line, m: where the rod
    goes into the barrel."""
    step = 0.5 * shot.metres_per_pixel()
    for s in np.arange(0.0, shot.length, step):
        col, row = shot.pixel(shot.at(s))
        if teal(shot.image[row, col]):
            return float(s)
    raise AssertionError("no teal along the pin line")


CASES = [("patu655", "lift"), ("electrohydraulic", "stick")]


def spec_of(name: str) -> ml.ManipulatorSpec:
    """A built-in arm or one of the test corpus."""
    return ml.builtin_spec(name) if name == "patu655" else ml.load_spec(ARMS / f"{name}.yaml")


@pytest.fixture(scope="module", params=CASES, ids=[f"{a}-{j}" for a, j in CASES])
def case(request: pytest.FixtureRequest) -> tuple[ml.ManipulatorSpec, str, list[Shot]]:
    """An arm, its joint with a pinned cylinder, and two frames of it at both ends of a ramp."""
    name, joint = request.param
    spec = spec_of(name)
    return spec, joint, shots(spec, joint)


def test_the_barrel_runs_from_the_parent_pin_and_the_rod_reaches_the_child_pin(case) -> None:
    """Teal along the pin line over most of the retracted length from the parent pin, chrome
    next to the child pin, in every frame."""
    spec, joint, taken = case
    cylinder = spec.joint(joint).actuator.cylinder
    for shot in taken:
        # the barrel covers the retracted cylinder's length bar the end caps, from the parent pin
        for f in (0.15, 0.35, 0.55, 0.75):
            point = shot.at(shot.length - f * float(cylinder.min_length))
            assert shot.looks(point, teal), (f, shot.pixel(point))
        # the rod, 5 cm from the child pin (no frame here has less than 14 cm of it out)
        near = shot.at(0.05)
        assert shot.looks(near, chrome), shot.pixel(near)
        assert not shot.looks(near, teal)


def test_the_rod_slides_out_of_the_barrel_with_the_stroke(case) -> None:
    """Between two frames the barrel's end stays put relative to the parent pin and moves away
    from the child pin by as much as the pins moved apart (to a couple of pixels)."""
    _, _, (first, last) = case
    assert abs(last.length - first.length) > 0.1  # the joint moved the cylinder a good part
    tolerance = 3.0 * max(first.metres_per_pixel(), last.metres_per_pixel())
    rods = barrel_end(first), barrel_end(last)
    assert rods[1] - rods[0] == pytest.approx(last.length - first.length, abs=tolerance)
    assert last.length - rods[1] == pytest.approx(first.length - rods[0], abs=tolerance)


def test_an_arm_without_pinned_cylinders_shows_no_teal() -> None:
    """The erector's joints are driven directly: not one teal pixel (where patu655 has many)."""
    spec = ml.builtin_spec("erector")
    assert not [j for j in spec.joints if getattr(j.actuator, "cylinder", None) is not None]
    frames = ml.render(ramp(spec, 2), width=W, height=H, fps=1.0, progress=False,
                       antialias=False)
    assert not teal(frames).any()
    # the same look finds the teal of an arm that has them
    assert teal(ml.render(ramp(ml.builtin_spec("patu655"), 1), width=W, height=H, fps=1.0,
                          progress=False, antialias=False)).sum() > 10


def test_a_ghosts_cylinders_are_in_its_run_colour_and_translucent() -> None:
    """In an overlay the reference arm's barrels and rods are opaque in their colours, the
    ghost's in its run colour at the ghosts' opacity, casting no shadow."""
    from maniplab.viz.scene import SceneView  # an overlay's scene
    from maniplab.viz.timeline import sample

    runs = [ramp(ml.builtin_spec("patu655"), 2), ramp(ml.builtin_spec("patu655"), 2, 0.3, 0.6)]
    motions = [sample(run, np.array([0.0, 1.0])) for run in runs]
    with SceneView(motions, W, H, Look("auto", False, False, False, False, None)) as view:
        view.frame(0)
        scene = view.scene
        parts = [scene.geoms[i] for i in range(scene.ngeom)
                 if scene.geoms[i].type == mujoco.mjtGeom.mjGEOM_CYLINDER
                 and scene.geoms[i].objtype == mujoco.mjtObj.mjOBJ_UNKNOWN]
    assert len(parts) == 8  # lift and tilt, barrel and rod, two arms
    ghost = palette.run_colour(1)
    for part in parts[4:]:
        assert part.rgba[:3] == pytest.approx(ghost[:3], abs=1e-6)
        assert part.rgba[3] == pytest.approx(palette.GHOST_ALPHA)
        assert part.transparent and not part.castshadow
    for part, colour in zip(parts[:4], (BARREL, ROD) * 2):
        assert part.rgba == pytest.approx(colour, abs=1e-6)
        assert not part.transparent
