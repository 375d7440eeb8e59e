"""Diagnosis: compare model and measurement, say where the model fails and which
physical effect is missing, add it and watch the error fall.

- :mod:`.residuals`: is a residual noise or structure, and where (statistics);
- :mod:`.models`: force models of the base law plus effects, bound to a measured history;
- :mod:`.data`: the curve as diagnosed (segments, baseline, contact guess, binning, noise);
- :mod:`.evidence`: which effects can show in the data, and which measurement separates two;
- :mod:`.workflow`: :func:`diagnose`, the ranking of candidate effects and the ladder;
- :mod:`.report`: figures and a self-contained HTML page.
"""

from .report import write_report
from .residuals import ResidualAnalysis, analyse_residuals, describe_structure, effective_sample_size
from .workflow import CANDIDATES, Diagnosis, diagnose

__all__ = ["CANDIDATES", "Diagnosis", "ResidualAnalysis", "analyse_residuals", "describe_structure", "diagnose",
           "effective_sample_size", "write_report"]
