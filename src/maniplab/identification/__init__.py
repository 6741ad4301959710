"""System identification: fit a spec's parameters to measurements from a real arm.

- :func:`identify` (``ml.identify``): the plant simulated under the measured inputs, its
  parameters fitted by bounded least squares, with confidence intervals and correlations.
- :mod:`~maniplab.identification.data`: experiments from CSV or run files.
- :func:`write_figure`: measured against fitted signals.
- :func:`~maniplab.identification.suggest.suggest`: experiments that make chosen parameters
  identifiable (``maniplab identify --suggest``).
"""

from __future__ import annotations

from maniplab.identification.data import DataError, Experiment, load_experiments, save_csv
from maniplab.identification.fit import Identification, IdentificationError, identify, write_figure
from maniplab.identification.parameters import Parameter, parse_parameters
from maniplab.identification.suggest import Suggestion, suggest

__all__ = ["DataError", "Experiment", "Identification", "IdentificationError", "Parameter",
           "Suggestion", "identify", "load_experiments", "parse_parameters", "save_csv", "suggest",
           "write_figure"]
