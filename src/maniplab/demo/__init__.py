"""The main job on the built-in erector (``maniplab demo``) and its HTML report."""

from maniplab.demo.pipeline import Demo
from maniplab.demo.report import Section, write_report

__all__ = ["Demo", "Section", "write_report"]
