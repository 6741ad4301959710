"""The offline HTML replay's own player: runs posed by MuJoCo in Python, drawn by a small WebGL
page (``player.html`` and ``player.js``, package data) that needs no network and no server.

Per frame and per drawn part (each MuJoCo geom with a surface, each pinned cylinder's barrel and
rod) the page gets a pose (position, rotation, length scale) and a colour (a joint blue while it
sticks, red at a limit); it only multiplies matrices and draws. The first run is solid, the others
translucent ghosts in their run colours; the end-effector paths are lines. The data is inline,
zlib-compressed and base64-encoded; the page inflates it with the browser's
``DecompressionStream``.
"""

from __future__ import annotations

import base64
import dataclasses
import html
import json
import zlib
from collections.abc import Sequence
from importlib import resources
from typing import Any

import mujoco
import numpy as np
import trimesh

from maniplab.gui.arm3d import geom_mesh
from maniplab.gui.replay import ReplayError, framing, replay_frames
from maniplab.sim.run import Run
from maniplab.viz import palette
from maniplab.viz.arm import ArmView
from maniplab.viz.cylinders import BARREL, ROD, cylinder_parts, pinned_cylinders, tendon_segments
from maniplab.viz.timeline import Motion, sample

POSE = 8
"""Floats per part per frame: position (3, m), rotation quaternion (w, x, y, z), length scale."""

_SEGMENTS = 24  # facets around a cylinder part
_TENDON = (0.35, 0.37, 0.40, 1.0)  # a tendon that is no pinned cylinder, drawn as a line
_BACKGROUND = palette.BACKGROUND


@dataclasses.dataclass
class _Blob:
    """Arrays packed one after another (each 4-byte aligned); ``index`` names their places."""

    chunks: list[bytes] = dataclasses.field(default_factory=list)
    size: int = 0
    index: dict[str, list[Any]] = dataclasses.field(default_factory=dict)

    def add(self, name: str, array: np.ndarray) -> str:
        kind = {np.dtype(np.float32): "f4", np.dtype(np.uint32): "u4",
                np.dtype(np.uint8): "u1"}[array.dtype]
        data = np.ascontiguousarray(array).tobytes()
        self.index[name] = [kind, self.size, int(array.size)]
        pad = -len(data) % 4
        self.chunks.append(data + b"\0" * pad)
        self.size += len(data) + pad
        return name


class _Scene:
    """Meshes (shared between parts that look the same), parts, colours, and per-frame poses."""

    def __init__(self) -> None:
        self.blob = _Blob()
        self.meshes: list[str] = []
        self._mesh_keys: dict[bytes, int] = {}
        self.colours: list[list[float]] = []
        self._colour_keys: dict[tuple[float, ...], int] = {}

    def mesh(self, surface: trimesh.Trimesh) -> int:
        """Index of ``surface`` (vertices m) among the meshes, added when new."""
        smooth = surface.smooth_shaded  # vertices split at sharp edges: boxes stay flat-faced
        vertices = np.asarray(smooth.vertices, dtype=np.float32)
        faces = np.asarray(smooth.faces, dtype=np.uint32)
        key = vertices.tobytes() + faces.tobytes()
        if key not in self._mesh_keys:
            k = len(self.meshes)
            self.blob.add(f"mesh{k}.p", vertices)
            self.blob.add(f"mesh{k}.n", np.asarray(smooth.vertex_normals, dtype=np.float32))
            self.blob.add(f"mesh{k}.i", faces)
            self.meshes.append(f"mesh{k}")
            self._mesh_keys[key] = k
        return self._mesh_keys[key]

    def colour(self, rgba: Sequence[float]) -> int:
        """Index of colour ``rgba`` (0..1) in the colour table, added when new."""
        key = tuple(round(float(c), 4) for c in rgba[:3])
        if key not in self._colour_keys:
            if len(self.colours) > 255:  # the frames' colour indices are bytes
                raise ReplayError("more than 256 colours in one replay")
            self._colour_keys[key] = len(self.colours)
            self.colours.append(list(key))
        return self._colour_keys[key]


@dataclasses.dataclass
class _Part:
    """One drawn part of one run: its mesh, hover name and radius scale (cylinder parts)."""

    mesh: int
    name: str
    radius: float = 1.0


def _unit_cylinder() -> trimesh.Trimesh:
    """A cylinder of radius 1 from z = 0 to z = 1 (placed at its start, scaled)."""
    unit = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=_SEGMENTS)
    unit.apply_translation((0.0, 0.0, 0.5))
    return unit


def _geom_rgba(view: ArmView, geom: int, modes: np.ndarray,
               tint: palette.RGBA | None) -> Sequence[float]:
    """Colour of geom ``geom`` with joint ``modes``, as the GUI's 3D arm colours it."""
    own = view.geom_colour(geom, modes, tint)
    if own is not None:
        return own
    model = view.model
    material = int(model.geom_matid[geom])
    return model.mat_rgba[material] if material >= 0 else model.geom_rgba[geom]


def _hover_name(view: ArmView, geom: int) -> str:
    """What hovering geom ``geom`` names: the joint that moves its body, else the geom's name."""
    model = view.model
    body = int(model.geom_bodyid[geom])
    if model.body_jntnum[body] > 0:
        return str(model.joint(int(model.body_jntadr[body])).name)
    return str(model.geom(geom).name or model.body(body).name or "base")


class _RunTrack:
    """One run's parts and what they do frame by frame: poses (F, P, POSE), colour indices
    (F, P), end-effector path (F, 3) m, and the tendon lines (F, L, 2, 3) m."""

    def __init__(self, scene: _Scene, motion: Motion, tint: palette.RGBA | None) -> None:
        self.view = view = ArmView(motion.run.spec)
        self.motion, self.tint = motion, tint
        model = view.model
        surfaces = {g: geom_mesh(model, g) for g in range(model.ngeom)}
        self.surfaces = {g: np.asarray(s.vertices) for g, s in surfaces.items() if s is not None}
        self.geoms = list(self.surfaces)
        self.parts = [_Part(scene.mesh(s), _hover_name(view, g))
                      for g, s in surfaces.items() if s is not None]
        self.cylinders = pinned_cylinders(model, view.spec)
        unit = scene.mesh(_unit_cylinder())
        for _, joint, cylinder in self.cylinders:
            parts = cylinder_parts(np.zeros((2, 3)), cylinder)
            self.parts += [_Part(unit, f"{joint} cylinder", float(scale[0]))
                           for _, _, scale in parts]
        pinned = {k for k, _, _ in self.cylinders}
        self.lines = [k for k in range(model.ntendon) if k not in pinned]

    def record(self, scene: _Scene) -> dict[str, np.ndarray]:
        """Pose the arm at every frame: the arrays the page plays."""
        view, motion = self.view, self.motion
        frames, count = len(motion.times), len(self.parts)
        poses = np.zeros((frames, count, POSE), dtype=np.float32)
        colours = np.zeros((frames, count), dtype=np.uint8)
        path = np.zeros((frames, 3), dtype=np.float32)
        lines = np.zeros((frames, len(self.lines), 2, 3), dtype=np.float32)
        barrel, rod = (scene.colour(self.tint or c) for c in (BARREL, ROD))
        quat = np.empty(4)
        for f in range(frames):
            view.pose(motion.q[f])
            data = view.data
            for p, geom in enumerate(self.geoms):
                mujoco.mju_mat2Quat(quat, data.geom_xmat[geom])
                poses[f, p] = (*data.geom_xpos[geom], *quat, 1.0)
                colours[f, p] = scene.colour(_geom_rgba(view, geom, motion.modes[f], self.tint))
            segments = tendon_segments(view.model, data)
            p = len(self.geoms)
            for tendon, _, cylinder in self.cylinders:
                for (start, wxyz, scale), colour in zip(cylinder_parts(segments[tendon], cylinder),
                                                        (barrel, rod)):
                    poses[f, p] = (*start, *wxyz, scale[2])
                    colours[f, p] = colour
                    p += 1
            lines[f] = segments[self.lines]
            path[f] = view.end_effector_position
        return {"poses": poses, "colours": colours, "path": path, "lines": lines}

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The arm's box at the first frame, every surface vertex, m (each shape (3,))."""
        view = self.view
        view.pose(self.motion.q[0])
        data = view.data
        points = [data.geom_xpos[g] + v @ data.geom_xmat[g].reshape(3, 3).T
                  for g, v in self.surfaces.items()]
        points.append(view.end_effector_position[None, :])
        every = np.vstack(points)
        return every.min(axis=0), every.max(axis=0)


def player_data(runs: Sequence[Run], fps: float = 30.0,
                labels: Sequence[str] | None = None) -> tuple[dict[str, Any], bytes]:
    """What the page plays: its description (JSON-able) and the packed arrays (uncompressed).

    Args:
        runs: the runs (at least one); run k > 0 is a ghost of colour ``run_colour(k)``.
        fps: frames per second of run time, 1/s (lowered so that at most
            :data:`~maniplab.gui.replay.MAX_FRAMES`).
        labels: each run's name in the key (default: the runs' labels).
    """
    fps, times = replay_frames(runs, fps)
    scene = _Scene()
    tracks = [_RunTrack(scene, sample(run, times), None if k == 0 else palette.run_colour(k))
              for k, run in enumerate(runs)]
    described, traced = [], []
    for k, track in enumerate(tracks):
        arrays = track.record(scene)
        traced.append(arrays["path"])
        described.append({
            "label": (labels[k] if labels is not None else runs[k].label) or f"run {k + 1}",
            "ghost": k > 0,
            "colour": list(palette.run_colour(k)[:3]),
            "path_colour": list((palette.PATH if len(runs) == 1 else palette.run_colour(k))[:4]),
            "line_colour": list((track.tint or _TENDON)[:3]),
            "parts": [dataclasses.asdict(p) for p in track.parts],
            "arrays": {name: scene.blob.add(f"run{k}.{name}", a) for name, a in arrays.items()},
            "lines": len(track.lines)})
    boxes = [t.bounds() for t in tracks]  # the arms at the first frame, and their paths
    lo = np.min([b[0] for b in boxes] + [p.min(axis=0) for p in traced], axis=0)
    hi = np.max([b[1] for b in boxes] + [p.max(axis=0) for p in traced], axis=0)
    frame = framing([run.spec for run in runs], (lo, hi))
    meta = {
        "t0": float(times[0]), "fps": float(fps), "frames": len(times),
        "runs": described, "meshes": scene.meshes, "colours": scene.colours,
        "blob": scene.blob.index, "ghost_alpha": palette.GHOST_ALPHA,
        "background": list(_BACKGROUND[:3]),
        "states": {"stick": list(palette.STICK[:3]) if palette.STICK else None,
                   "limit": list(palette.LIMIT[:3]) if palette.LIMIT else None},
        "camera": {"position": frame.position.tolist(), "target": frame.look_at.tolist(),
                   "up": frame.up.tolist(), "fov": frame.fov},
        "floor": {"up_axis": frame.up_axis, "size": frame.grid, "cell": frame.cell,
                  "section": frame.section, "axes": frame.axes_length,
                  "axes_radius": frame.axes_radius, "axes_mesh": scene.mesh(_unit_cylinder())}}
    return meta, b"".join(scene.blob.chunks)


def replay_html(runs: Sequence[Run], fps: float = 30.0,
                names: Sequence[str] | None = None) -> str:
    """A self-contained HTML page replaying ``runs`` in 3D with the player of ``player.js``
    (WebGL, the arms posed by MuJoCo at every frame, all inline; it opens from a file, offline):
    the first run solid, the others as ghosts, the end-effector paths traced; orbit, zoom,
    play/pause (space bar), a time slider, a speed choice, a key naming each run, and the joint
    under the pointer named. ``fps`` as :class:`~maniplab.gui.replay.Replay` takes it; ``names``:
    each run's name (default: the runs' labels), with the parameters in which the runs differ
    added to it."""
    from maniplab.gui.runs import legend

    labels = legend(list(runs), list(names) if names is not None else
                    [run.label or f"run {k + 1}" for k, run in enumerate(runs)]) if runs else None
    meta, blob = player_data(runs, fps, labels)
    folder = resources.files("maniplab.gui")
    page = folder.joinpath("player.html").read_text(encoding="utf-8")
    script = folder.joinpath("player.js").read_text(encoding="utf-8")
    data = base64.b64encode(zlib.compress(blob, 6)).decode("ascii")
    title = " vs ".join(r["label"] for r in meta["runs"])
    return (page.replace("{{TITLE}}", html.escape(f"maniplab replay: {title}"))
            .replace("{{META}}", json.dumps(meta).replace("<", "\\u003c"))  # no tag in it
            .replace("{{DATA}}", data)
            .replace("{{SCRIPT}}", script.replace("</script", "<\\/script")))
