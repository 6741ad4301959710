"""AnalyticModel: the arm's equations of motion and kinematics as fast numeric functions."""

from __future__ import annotations

import ctypes
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from maniplab.model.build import load_kernels
from maniplab.model.errors import ModelArgumentError
from maniplab.model.inertial import inertial_parameters
from maniplab.spec import ManipulatorSpec

_LIBRARIES: dict[str, ctypes.CDLL] = {}  # a compiled model's file -> its ctypes handle


class AnalyticModel:
    """M(q), C(q, q̇), G(q), friction, kinematics and stuck-joint dynamics of one arm, compiled.

    The recursive algorithms of rigid-body dynamics (Newton-Euler for the forces, composite
    rigid bodies for M, Echeandia-Wensing for the Christoffel C) are recorded once for the arm's
    structure as straight-line code and compiled to C (or run as generated Python when there is
    no C compiler); the code grows about linearly with the number of joints. It depends only on
    the arm's structure; the spec's values are a runtime parameter vector, so arms that differ
    only in masses, lengths or payload share it. The readable closed forms of M, C and G are
    :meth:`symbolic`'s.

    Every state argument is one state, shape (n,), or a batch, shape (N, n): a batch returns a
    leading N axis and is looped in C. Units: q in rad (R joints) or m (P joints), q̇ in rad/s or
    m/s, q̈ in rad/s² or m/s², forces in N·m or N.

    Args:
        spec: the arm.
        backend: "auto" (C when a compiler is available, else Python), "c" or "python".
        cache: use the on-disk cache (``$MANIPLAB_CACHE``, default ~/.cache/maniplab).
        progress: show a progress bar while generating (None: only on a terminal).

    Example:
        >>> am = AnalyticModel(builtin_spec("planar2"))
        >>> tau = am.inverse_dynamics(q, qd, qdd)   # M q̈ + C q̇ + G, as mujoco.mj_inverse
    """

    def __init__(self, spec: ManipulatorSpec, *, backend: str = "auto", cache: bool = True,
                 progress: bool | None = None) -> None:
        self.spec = spec
        self.n = spec.n
        inertial = inertial_parameters(spec)
        self.params = inertial.values
        """The runtime parameter vector p the kernels read, shape (P,): each body's standard
        inertial parameters (payload included), offsets, gravity (see :attr:`param_labels`)."""
        self.param_labels: tuple[str, ...] = inertial.labels
        self.params.setflags(write=False)
        self._k = load_kernels(spec, backend, use_cache=cache, progress=progress)
        self.backend: str = self._k.backend
        fv = np.array([j.friction.viscous for j in spec.joints], dtype=float)
        self._fv = fv
        self.Fv = np.diag(fv)
        """Viscous friction matrix Fv (diagonal), shape (n, n), N·s/m or N·m·s/rad."""

    def __repr__(self) -> str:
        return f"AnalyticModel({self.spec.name!r}, n={self.n}, backend={self.backend!r})"

    # --- dynamics ----------------------------------------------------------------------------
    def M(self, q: ArrayLike) -> np.ndarray:
        """Inertia matrix M(q), shape (n, n) or (N, n, n); symmetric, kg / kg·m / kg·m²."""
        return self._k.M(self.params, q)

    def C(self, q: ArrayLike, qd: ArrayLike) -> np.ndarray:
        """Coriolis/centrifugal matrix in Christoffel form, shape (n, n) or (N, n, n).

        C_kj = Σ_i ½(∂M_kj/∂q_i + ∂M_ki/∂q_j - ∂M_ij/∂q_k) q̇_i, so Ṁ - 2C is skew-symmetric.
        """
        return self._k.C(self.params, q, qd)

    def G(self, q: ArrayLike) -> np.ndarray:
        """Gravity forces G(q) = ∂V/∂q, shape (n,) or (N, n), N·m or N."""
        return self._k.G(self.params, q)

    def bias(self, q: ArrayLike, qd: ArrayLike) -> np.ndarray:
        """C(q, q̇) q̇ + G(q), shape (n,) or (N, n): MuJoCo's ``qfrc_bias``."""
        return self._k.bias(self.params, q, qd)

    def mass_and_bias(self, q: ArrayLike, qd: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """M(q) and C q̇ + G in one evaluation: shapes (n, n), (n,) (or with a leading N)."""
        return self._k.mass_bias(self.params, q, qd)

    def friction(self, qd: ArrayLike) -> np.ndarray:
        """Viscous friction force Fv q̇, shape (n,) or (N, n)."""
        return self._fv * np.asarray(qd, dtype=float)

    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike, *,
                         friction: bool = False) -> np.ndarray:
        """Joint forces M q̈ + C q̇ + G (+ Fv q̇ when ``friction``), shape (n,) or (N, n).

        Without friction this is the rigid-body inverse dynamics, MuJoCo's ``mj_inverse``.
        """
        tau = self._k.inverse_dynamics(self.params, q, qd, qdd)
        if friction:
            tau += self._fv * np.asarray(qd, dtype=float)
        return tau

    def forward_dynamics(self, q: ArrayLike, qd: ArrayLike, tau: ArrayLike, *,
                         friction: bool = False) -> np.ndarray:
        """Joint accelerations q̈ = M⁻¹(τ - C q̇ - G (- Fv q̇)), shape (n,) or (N, n)."""
        M, b = self.mass_and_bias(q, qd)
        rhs = np.asarray(tau, dtype=float) - b
        if friction:
            rhs = rhs - self.friction(qd)
        return np.linalg.solve(M, rhs[..., None])[..., 0]

    def constrained_dynamics(self, q: ArrayLike, qd: ArrayLike, tau: ArrayLike,
                             stuck: Iterable[int | str] | ArrayLike, *,
                             friction: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Dynamics with some joints stuck (hybrid friction's STICK mode) and their holding force.

        A stuck joint is held at zero velocity and zero acceleration (its entry of ``qd`` is
        ignored and taken as 0). With F the free and S the stuck joints, the free joints obey
        ``M_FF q̈_F = τ_F - b_F`` with b = C q̇ + G (+ Fv q̇ when ``friction``) at q̇_S = 0, and the
        holding force is what the stiction must add to each stuck joint's force to keep it still:
        ``hold_S = M_SF q̈_F + b_S - τ_S`` (the paper's e·M_D(q)q̈ term is M_SF q̈_F).

        Args:
            q: joint positions, shape (n,) or (N, n).
            qd: joint velocities, same shape (entries of stuck joints ignored).
            tau: applied joint forces (actuator minus slipping friction), same shape, N·m or N.
            stuck: joint indices or names, or a boolean mask of shape (n,).
            friction: include viscous friction of the free joints.

        Returns:
            (qdd, hold): accelerations with zeros at stuck joints, and holding forces with zeros
            at free joints; both the shape of q. A joint's ``hold`` is in N·m or N, in the
            joint's positive direction.
        """
        mask = self._stuck_mask(stuck)
        qd = np.array(qd, dtype=float)
        qd[..., mask] = 0.0
        M, b = self.mass_and_bias(q, qd)
        if friction:
            b = b + self.friction(qd)
        rhs = np.asarray(tau, dtype=float) - b
        free = ~mask
        qdd = np.zeros_like(rhs)
        if free.any():
            M_ff = M[..., free, :][..., :, free]
            qdd[..., free] = np.linalg.solve(M_ff, rhs[..., free][..., None])[..., 0]
        hold = np.zeros_like(rhs)
        hold[..., mask] = np.einsum("...ij,...j->...i", M[..., mask, :], qdd) - rhs[..., mask]
        return qdd, hold

    def _stuck_mask(self, stuck: Any) -> np.ndarray:
        """Boolean mask (n,) from joint names, indices, or a mask."""
        if isinstance(stuck, (str, int, np.integer)):
            stuck = [stuck]
        arr = np.asarray(stuck)
        if arr.dtype == bool:
            if arr.shape != (self.n,):
                raise ModelArgumentError(f"stuck mask must have shape ({self.n},), got {arr.shape}")
            return arr.copy()
        mask = np.zeros(self.n, dtype=bool)
        for key in stuck:
            mask[self.spec.joint_index(key if isinstance(key, str) else int(key))] = True
        return mask

    # --- kinematics --------------------------------------------------------------------------
    def fk(self, q: ArrayLike) -> np.ndarray:
        """End-effector pose in the base frame, 4x4 homogeneous, shape (4, 4) or (N, 4, 4), m.

        The end-effector frame is the frame after the last body moved by ``end_effector.offset``
        (the payload point), with the orientation of the last frame.
        """
        return self._k.fk(self.params, q)

    def jacobian(self, q: ArrayLike) -> np.ndarray:
        """Geometric Jacobian of the end-effector point, base frame, shape (6, n) or (N, 6, n).

        Rows 0-2 map q̇ to the point's linear velocity (m/s), rows 3-5 to the angular velocity
        (rad/s).
        """
        return self._k.jacobian(self.params, q)

    # --- the compiled kernels for C callers --------------------------------------------------
    def kernel_address(self, name: str) -> int:
        """The address of the compiled kernel ``ml_<name>`` (name: M, C, G, bias, mass_bias,
        inverse_dynamics, fk, jacobian), for C code that calls the model itself (the compiled
        cascade): ``void ml_<name>(const double *p, const double *q, const double *qd,
        const double *qdd, double *out)`` with ``p`` = :attr:`params` (see
        :mod:`~maniplab.model.tape`).

        Raises:
            ModelArgumentError: the model runs on the Python backend (nothing compiled).
        """
        if self.backend != "c":
            raise ModelArgumentError(
                f"the {self.spec.name} model runs on the {self.backend!r} backend: it has no "
                "compiled kernels (it needs a C compiler)")
        lib = _LIBRARIES.get(self._k.__file__)
        if lib is None:
            lib = _LIBRARIES.setdefault(self._k.__file__, ctypes.CDLL(self._k.__file__))
        address = ctypes.cast(getattr(lib, f"ml_{name}"), ctypes.c_void_p).value
        assert address is not None, name
        return address

    # --- the symbolic side -------------------------------------------------------------------
    def symbolic(self, symbolic: Sequence[str] = ()) -> Any:
        """The arm's :class:`~maniplab.model.symbolic.SymbolicModel` (sympy matrices)."""
        from maniplab.model.symbolic import SymbolicModel

        return SymbolicModel(self.spec, symbolic=symbolic)
