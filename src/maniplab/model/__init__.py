"""The analytic model: recursive dynamics recorded as straight-line code and compiled; readable
symbolic equations on demand.

- :class:`AnalyticModel` (``ml.AnalyticModel``): numeric M, C, G, inverse/forward dynamics,
  stuck-joint dynamics, forward kinematics and Jacobian, one state or a batch (RNEA, CRBA and
  the Christoffel C recorded on a tape, see :mod:`~maniplab.model.recursive`).
- :class:`SymbolicModel`: sympy matrices (H, Jacobians, M, C, G, Fv) with chosen parameters kept
  as symbols.
- :func:`export_model`: LaTeX, Markdown, a self-contained Python module or C file.

This package never imports mujoco: it is checked against MuJoCo, so it is derived independently.
sympy is imported only when the symbolic side is used (it takes a quarter of a second).
"""

from __future__ import annotations

from typing import Any

from maniplab.model.analytic import AnalyticModel
from maniplab.model.parameters import GROUPS

__all__ = ["GROUPS", "AnalyticModel", "SymbolicModel", "export_model"]


def __getattr__(name: str) -> Any:
    if name == "SymbolicModel":
        from maniplab.model.symbolic import SymbolicModel

        return SymbolicModel
    if name == "export_model":
        from maniplab.model.export import export_model

        return export_model
    raise AttributeError(f"module 'maniplab.model' has no attribute {name!r}")
