"""The arm's inertial parameters as the recursive kernels read them: one block per body.

Each body carries its payload-free spec values folded into the ten standard parameters of rigid-body
dynamics, all in the body's own frame at its joint (the frame the spec writes it in):

- ``mass`` m, kg;
- ``first_moment`` h = m c, kg·m (c the centre of gravity);
- ``inertia`` about the joint, I_O = I_C + m (|c|² 1 - c cᵀ), kg·m² (xx, yy, zz, xy, xz, yz);

plus its ``offset`` to the next joint, m. The end-effector payload (its mass at its centre of
gravity, ``offset + com``, with its inertia about it) is fixed in the last body, so it is folded
into that body's parameters. The arm also has ``gravity`` (m/s²,
base axes) and the ``end-effector`` point (m, in the last body's frame).

The inverse dynamics is linear in the inertial parameters, which is why identification works on
exactly this set. Only the *structurally* non-zero entries become slots of the runtime parameter
vector: an entry is a slot when the spec values it is made of are not all exactly zero, decided
from which values are zero (the arm's structure), never from the arithmetic. Two arms of one
structure therefore share one compiled kernel, and a mass or payload sweep never recompiles.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from maniplab.spec import Joint, ManipulatorSpec, inertia_matrix

AXES = "xyz"
#: Inertia entries (row, column, label) in parameter order.
INERTIA_KEYS = ((0, 0, "xx"), (1, 1, "yy"), (2, 2, "zz"), (0, 1, "xy"), (0, 2, "xz"), (1, 2, "yz"))


@dataclasses.dataclass(frozen=True)
class Slot:
    """One entry of the arm's parameters: its value, whether it is a slot, and what it is."""

    value: float
    structural: bool
    label: str


@dataclasses.dataclass(frozen=True)
class BodyBlock:
    """One body's parameters (see the module docstring): slots m, h (3), I_O (6), offset (3)."""

    mass: Slot
    first_moment: tuple[Slot, Slot, Slot]
    inertia: tuple[Slot, ...]
    offset: tuple[Slot, Slot, Slot]

    def slots(self) -> list[Slot]:
        return [self.mass, *self.first_moment, *self.inertia, *self.offset]


@dataclasses.dataclass(frozen=True)
class InertialParameters:
    """Every parameter of the arm, in the runtime vector's order.

    Attributes:
        bodies: one block per joint (zeros where the joint carries nothing).
        gravity: m/s², base axes.
        end_effector: the payload point in the last body's frame, m.
    """

    bodies: tuple[BodyBlock, ...]
    gravity: tuple[Slot, Slot, Slot]
    end_effector: tuple[Slot, Slot, Slot]

    def all(self) -> list[Slot]:
        """Every entry in order: bodies, then gravity, then the end-effector point."""
        out = [s for b in self.bodies for s in b.slots()]
        return out + list(self.gravity) + list(self.end_effector)

    @property
    def values(self) -> np.ndarray:
        """The runtime vector p: the values of the slots, shape (P,) (a single 0 if P = 0)."""
        kept = [s.value for s in self.all() if s.structural]
        return np.array(kept or [0.0])

    @property
    def labels(self) -> tuple[str, ...]:
        """What each entry of :attr:`values` is, with its unit."""
        return tuple(s.label for s in self.all() if s.structural)


def inertial_parameters(spec: ManipulatorSpec) -> InertialParameters:
    """The spec's bodies and payload as standard inertial parameters (module docstring)."""
    n = spec.n
    ee = spec.end_effector
    last = spec.joints[-1]
    last_offset = _offset(last)
    point = [_Term(ee.offset[k] + last_offset[k].value,
                   ee.offset[k] != 0.0 or last_offset[k].structural) for k in range(3)]
    cog = [_Term(ee.offset[k] + ee.com[k] + last_offset[k].value,
                 ee.offset[k] != 0.0 or ee.com[k] != 0.0 or last_offset[k].structural)
           for k in range(3)]
    payload = ee.inertia_tensor
    bodies = []
    for j, joint in enumerate(spec.joints):
        masses = []
        body = joint.body
        if body is not None:
            assert body.com is not None and body.inertia is not None
            centre = [_Term(float(c), float(c) != 0.0) for c in body.com]
            masses.append((_Term(body.mass, body.mass != 0.0), centre,
                           inertia_matrix(body.inertia)))
        if j == n - 1 and (ee.mass != 0.0 or np.any(payload != 0.0)):
            masses.append((_Term(ee.mass, ee.mass != 0.0), cog, payload))
        bodies.append(_block(joint.name, masses, _offset(joint), payload=j == n - 1))
    gravity = tuple(Slot(float(g), g != 0.0, f"gravity {a}, m/s^2")
                    for a, g in zip(AXES, spec.gravity))
    end = tuple(Slot(t.value, t.structural, f"end-effector point {a} in the {last.name} frame, m")
                for a, t in zip(AXES, point))
    return InertialParameters(tuple(bodies), gravity, end)  # type: ignore[arg-type]


@dataclasses.dataclass(frozen=True)
class _Term:
    value: float
    structural: bool


def _offset(joint: Joint) -> list[Slot]:
    body = joint.body
    values = np.zeros(3) if body is None else body.length * np.asarray(body.direction, dtype=float)
    return [Slot(float(v), float(v) != 0.0, f"{joint.name} offset {a}, m")
            for a, v in zip(AXES, values)]


def _block(name: str, masses: list[tuple[_Term, list[_Term], np.ndarray]], offset: list[Slot],
           payload: bool) -> BodyBlock:
    """Sum the point/body masses of one body into m, h, I_O (values and structure)."""
    what = f"{name} body" + (" and payload" if payload and len(masses) > 0 else "")
    m, m_nz = 0.0, False
    h, h_nz = np.zeros(3), [False] * 3
    inertia, i_nz = np.zeros((3, 3)), np.zeros((3, 3), dtype=bool)
    for mass, centre, about_cog in masses:
        c = np.array([t.value for t in centre])
        c_nz = [mass.structural and t.structural for t in centre]
        m += mass.value
        m_nz |= mass.structural
        h += mass.value * c
        inertia += about_cog + mass.value * (float(c @ c) * np.eye(3) - np.outer(c, c))
        i_nz |= about_cog != 0.0
        for r in range(3):
            h_nz[r] |= c_nz[r]
            for s in range(3):
                i_nz[r, s] |= any(c_nz[k] for k in range(3) if k != r) if r == s else \
                    (c_nz[r] and c_nz[s])
    return BodyBlock(
        mass=Slot(m, m_nz, f"{what} mass, kg"),
        first_moment=tuple(Slot(float(h[k]), h_nz[k], f"{what} first moment m*c{a}, kg m")
                           for k, a in enumerate(AXES)),  # type: ignore[arg-type]
        inertia=tuple(Slot(float(inertia[r, s]), bool(i_nz[r, s]),
                           f"{what} inertia {key} about the joint, kg m^2")
                      for r, s, key in INERTIA_KEYS),
        offset=tuple(offset),  # type: ignore[arg-type]
    )
