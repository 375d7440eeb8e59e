"""Diagnosis: compare model and measurement, say where the model fails and which
physical effect is missing, add it and watch the error fall.

- :mod:`skin_indent.inverse.residuals`: is a residual noise or structure, and where (statistics);
- :mod:`skin_indent.fitting.multistart`: the fits of one diagnosis, each a :class:`Rung`;
- :mod:`.identifiability`: the one engine of the next measurement: what the curve determines, which
  measurement would separate the explanations and determine the rest (the diagnosis' sentences and
  :func:`plan` read it);
- :mod:`.measurements`: the measurements a user can make next, as their points would be recorded;
  :mod:`.prediction`: what fitted models predict for them (every finite-element run through one
  function); :mod:`.separation`: how far apart two explanations' curves lie; :mod:`.information`:
  what a measurement would determine fitted with the recorded curves;
- :mod:`.evidence`: the sentence naming the measurement that separates two explanations;
- :mod:`.workflow`: :func:`diagnose`, the ranking of candidate effects and the ladder;
- :mod:`.criteria`: what it decides by (the BIC margins, the noise allowance, :func:`~.criteria.explained`);
- :mod:`.result`: its outcome, :class:`Diagnosis`: the text, sentence and JSON of one set of numbers
  (the text written by :mod:`.result_text`);
- :mod:`.planning`: :func:`plan`, the next measurement: the candidates ranked by how well they
  would separate the explanations a diagnosis left and determine its undetermined parameters;
- :mod:`.batch`: :func:`diagnose_many`, every curve of files, folders and force maps, in parallel,
  one :class:`DiagnosisRow` each;
- :mod:`.report`: figures and a self-contained HTML page.

The curve is prepared by :func:`skin_indent.measurement.prepare` (as for fits), and the
candidate effects are the registered ones (:mod:`skin_indent.effects`).
"""

from ..fitting.rung import MODEL_ERROR, Rung
from ..inverse.residuals import ResidualAnalysis, analyse_residuals, describe_structure, effective_sample_size
from .planning import Plan, plan
from .workflow import Diagnosis, diagnose
from .batch import DiagnosisBatch, DiagnosisRow, diagnose_many

__all__ = ["MODEL_ERROR", "Diagnosis", "DiagnosisBatch", "DiagnosisRow", "Plan", "ResidualAnalysis", "Rung",
           "analyse_residuals", "describe_structure", "diagnose", "diagnose_many", "effective_sample_size",
           "plan"]
