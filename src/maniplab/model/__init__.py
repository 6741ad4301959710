"""The analytic model: symbolic equations of motion from the spec, compiled for fast evaluation.

- :class:`AnalyticModel` (``ml.AnalyticModel``): numeric M, C, G, inverse/forward dynamics,
  stuck-joint dynamics, forward kinematics and Jacobian, one state or a batch.
- :class:`SymbolicModel`: sympy matrices (H, Jacobians, M, C, G, Fv) with chosen parameters kept
  as symbols.
- :func:`export`: LaTeX, Markdown, a self-contained Python module or C file.

This package never imports mujoco: it is checked against MuJoCo, so it is derived independently.
"""

from __future__ import annotations

from maniplab.model.analytic import AnalyticModel
from maniplab.model.parameters import GROUPS
from maniplab.model.symbolic import SymbolicModel

__all__ = ["GROUPS", "AnalyticModel", "SymbolicModel"]
