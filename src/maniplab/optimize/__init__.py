"""Co-design: optimise an arm and its controller together (``maniplab optimize``).

A study (:mod:`~maniplab.optimize.study`) names the base spec, design variables by the dotted
paths of ``--set`` (continuous, integer, or from a catalogue such as ISO 3320's bores), and
objectives and constraints over the metrics of :mod:`~maniplab.optimize.metrics` (load chart,
holding, duty-cycle dynamics, energy, health, plugins). :func:`optimize` searches with scipy's
differential evolution or optuna's NSGA-II (:mod:`~maniplab.optimize.search`), every evaluation
cached by the candidate's content (:mod:`~maniplab.optimize.cache`), and writes the best spec
or the Pareto set, the evaluations and a report (:mod:`~maniplab.optimize.report`).
"""

from __future__ import annotations

import sys
import types
from typing import Any

from maniplab.optimize.catalogue import CATALOGUES
from maniplab.optimize.errors import StudyError
from maniplab.optimize.run import OptimizeResult, optimize
from maniplab.optimize.study import Study, load_study

__all__ = ["CATALOGUES", "OptimizeResult", "Study", "StudyError", "load_study", "optimize"]


class _CallableModule(types.ModuleType):
    """This package, callable as :func:`optimize`: importing ``maniplab.optimize`` binds the
    package to the name ``optimize`` of ``maniplab``, where the public function ``ml.optimize``
    also lives, so both must answer ``ml.optimize(study, out=...)``."""

    def __call__(self, *args: Any, **kwargs: Any) -> OptimizeResult:
        return optimize(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
