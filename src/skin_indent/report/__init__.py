"""Every figure, table and page the package writes from its results.

- :mod:`.paper`: figures of the paper's identification (fits, residuals, filter histories);
- :mod:`.fit_figure`: the figure and CSV of one fitted curve;
- :mod:`.batch_table`: the table of a batch of fits and its summary figure;
- :mod:`.diagnosis_page`: the figures and HTML page of a diagnosis;
- :mod:`.plan_figure`: the predicted curves (CSV) and the figure of a plan of the next measurement;
- :mod:`.verdict_map`: the verdicts of a batch of diagnoses, per curve and over each force map;
- :func:`save_figure`: every PNG, with its provenance in its metadata.
"""

from .batch_table import summary_figure, write_tsv
from .diagnosis_page import write_report
from .fit_figure import fit_arrays, plot_fit, write_fit_csv
from .plan_figure import plan_figure, write_plan
from .verdict_map import write_batch_figures
from ._save import save_figure

__all__ = ["fit_arrays", "plan_figure", "plot_fit", "save_figure", "summary_figure", "write_batch_figures",
           "write_fit_csv", "write_plan", "write_report", "write_tsv"]
