"""The spec's physical parameters as they enter the symbolic equations: symbols or numbers.

Each quantity of the arm (a body's mass, centre of gravity, inertia and offset, the payload, the
gravity vector, the viscous friction) enters the readable derivation as one of

- a **named symbol** (``m1``, ``l2``, ``me``...) when its group is asked to stay symbolic, so a
  designer can read how it enters M, C and G;
- a **number** otherwise.

:func:`structure_key` is what the compiled kernels depend on: the arm's structure (axes, joint
types, which values are zero), never the non-zero values, which are a runtime parameter vector
(see :mod:`~maniplab.model.inertial`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Iterable
from typing import Any

import numpy as np

from maniplab.model.engine import Engine, Expr, Mat, Vec
from maniplab.model.errors import ModelArgumentError
from maniplab.spec import ManipulatorSpec, inertia_matrix

#: Parameter groups that SymbolicModel can keep as symbols, and the symbols they introduce.
GROUPS: dict[str, str] = {
    "mass": "m1..mn: body masses, kg (bodies with mass only)",
    "length": "l1..ln: body lengths, m (bodies with length only); a default COG stays l/2",
    "com": "c1x..: body centres of gravity in the joint frame, m",
    "inertia": "I1xx..: body inertias about the COG, kg·m² (non-zero entries only)",
    "payload": "me: end-effector (payload) mass, kg",
    "offset": "ex, ey, ez: end-effector offset, m (non-zero entries only)",
    "gravity": "gx, gy, gz: gravity, m/s² (non-zero entries only)",
    "friction": "fv1..fvn: viscous friction, N·s/m or N·m·s/rad",
}

_AXES = "xyz"
_INERTIA_KEYS = ((0, 0, "xx"), (1, 1, "yy"), (2, 2, "zz"), (0, 1, "xy"), (0, 2, "xz"), (1, 2, "yz"))


@dataclasses.dataclass
class BodyTerms:
    """One body's parameters as expressions (all in its joint frame, base axes at q = 0).

    Attributes:
        mass: kg.
        com: centre of gravity, m, three expressions.
        inertia: about the COG, kg·m², 3x3 nested list.
        offset: translation to the next joint (length · direction), m, three expressions.
    """

    mass: Expr
    com: Vec
    inertia: Mat
    offset: Vec


@dataclasses.dataclass
class ArmTerms:
    """The whole arm's parameters as expressions.

    Attributes:
        bodies: one per joint (zeros where the joint has no body).
        ee_mass: payload mass, kg.
        ee_offset: the end-effector point in the last frame, m.
        ee_com: the payload's centre of gravity relative to that point, m (numbers).
        ee_inertia: the payload's inertia about its centre of gravity, kg·m², 3x3 (numbers).
        gravity: m/s², base axes.
        viscous: viscous friction per joint.
        symbols: the named parameter symbols with their spec values (symbolic groups).
    """

    bodies: list[BodyTerms]
    ee_mass: Expr
    ee_offset: Vec
    ee_com: Vec
    ee_inertia: Mat
    gravity: Vec
    viscous: list[Expr]
    symbols: dict[Any, float] = dataclasses.field(default_factory=dict)


class _Maker:
    """Makes each quantity a named symbol or a number, and records the symbols it made."""

    def __init__(self, engine: Engine, symbolic: frozenset[str]) -> None:
        self.engine = engine
        self.symbolic = symbolic
        self.symbols: dict[Any, float] = {}

    def __call__(self, group: str, name: str, value: float) -> Expr:
        value = float(value)
        if value == 0.0:
            return self.engine.zero
        if group in self.symbolic:
            sym = self.engine.symbol(name)
            self.symbols[sym] = value
            return sym
        return self.engine.number(value)


def arm_terms(
    spec: ManipulatorSpec, engine: Engine, symbolic: Iterable[str] = ()
) -> ArmTerms:
    """The spec's parameters as expressions for a derivation.

    Args:
        spec: the arm.
        engine: the symbolic library.
        symbolic: groups kept as named symbols (keys of :data:`GROUPS`).

    Raises:
        ModelArgumentError: for an unknown group.
    """
    symbolic = frozenset(symbolic)
    unknown = symbolic - GROUPS.keys()
    if unknown:
        raise ModelArgumentError(f"unknown parameter group(s) {sorted(unknown)}; expected some "
                                 f"of {', '.join(GROUPS)}")
    make = _Maker(engine, symbolic)
    bodies = [_body_terms(spec, j, make) for j in range(spec.n)]
    ee = spec.end_effector
    return ArmTerms(
        bodies=bodies,
        ee_mass=make("payload", "me", ee.mass),
        ee_offset=[make("offset", f"e{a}", v)
                   for a, v in zip(_AXES, ee.offset)],
        ee_com=[make("", "", v) for v in ee.com],
        ee_inertia=[[make("", "", v) for v in row] for row in ee.inertia_tensor],
        gravity=[make("gravity", f"g{a}", v)
                 for a, v in zip(_AXES, spec.gravity)],
        viscous=[make("friction", f"fv{j + 1}", joint.friction.viscous)
                 for j, joint in enumerate(spec.joints)],
        symbols=make.symbols,
    )


def _body_terms(spec: ManipulatorSpec, j: int, make: _Maker) -> BodyTerms:
    joint, k, zero = spec.joints[j], j + 1, make.engine.zero
    body = joint.body
    if body is None:
        return BodyTerms(zero, [zero] * 3, [[zero] * 3 for _ in range(3)], [zero] * 3)
    e = np.asarray(body.direction)
    mass = make("mass", f"m{k}", body.mass)
    if "length" in make.symbolic and body.length > 0.0:
        length = make("length", f"l{k}", body.length)
        offset = [length * make.engine.number(c) for c in e]
    else:
        offset = [make("length", "", body.length * c) for c in e]
    com = _com_terms(k, body, e, offset, make)
    inertia = _inertia_terms(k, body, e, mass, offset, make)
    return BodyTerms(mass, com, inertia, offset)


def _com_terms(k: int, body: Any, e: np.ndarray, offset: Vec, make: _Maker) -> Vec:
    default = np.allclose(body.com, 0.5 * body.length * e, rtol=0.0, atol=1e-15)
    if default and "length" in make.symbolic and "com" not in make.symbolic:
        return [c * make.engine.rational(1, 2) for c in offset]
    return [make("com", f"c{k}{a}", v) for a, v in zip(_AXES, body.com)]


def _inertia_terms(k: int, body: Any, e: np.ndarray, mass: Expr, offset: Vec,
                   make: _Maker) -> Mat:
    matrix = inertia_matrix(body.inertia)
    rod = body.mass * body.length**2 / 12.0 * (np.eye(3) - np.outer(e, e))
    readable = make.symbolic & {"mass", "length"} and "inertia" not in make.symbolic
    if readable and np.allclose(matrix, rod, rtol=1e-12, atol=1e-300):
        # the spec's default slender rod, written as m l²/12 (1 - e eᵀ) in the symbols
        length_sq = sum(c * c for c in offset)
        scale = mass * length_sq * make.engine.rational(1, 12)
        eye = np.eye(3) - np.outer(e, e)
        return [[scale * make.engine.number(eye[r][c]) for c in range(3)] for r in range(3)]
    out = [[make.engine.zero] * 3 for _ in range(3)]
    for r, c, axes in _INERTIA_KEYS:
        out[r][c] = out[c][r] = make("inertia", f"I{k}{axes}", matrix[r, c])
    return out


def structure_key(spec: ManipulatorSpec) -> str:
    """A digest of everything the compiled kernels depend on (not the non-zero values).

    Two specs with the same digest share one generated kernel: axes, joint types, and which
    parameter values are exactly zero (what decides the slots of
    :func:`~maniplab.model.inertial.inertial_parameters`).
    """
    def nz(values: Iterable[float]) -> list[int]:
        return [int(float(v) != 0.0) for v in values]

    rows: list[Any] = []
    for joint in spec.joints:
        body = joint.body
        row: list[Any] = [joint.type.value, joint.axis.value]
        if body is not None:
            # Body.__post_init__ fills in a com and an inertia that were not given
            assert body.com is not None and body.inertia is not None
            row += [nz([body.mass]), nz(body.length * np.asarray(body.direction)), nz(body.com),
                    nz(body.inertia)]
        rows.append(row)
    ee = spec.end_effector
    rows.append([nz([ee.mass]), nz(ee.offset), nz(spec.gravity)])
    if any(ee.com) or any(ee.inertia):  # (kept out of the rows of arms without them: same key)
        rows.append(["payload", nz(ee.com), nz(ee.inertia)])
    return hashlib.sha256(json.dumps(rows).encode()).hexdigest()
