"""From a recorded curve to material parameters.

- :mod:`.surfaces`: which response surface serves a curve (cached or built);
- :mod:`.identification`: the paper's identification step on a surface (Hertz start, checks,
  the methods by name);
- :mod:`.one_fit`: :func:`fit`, the one fit of a recorded curve (or several of one sample): the
  model's fit by the multistart fitter (``fit(m)`` is ``fit(m, model="neo-hooke")``), the paper's
  identification an option of it;
- :mod:`.curve`: the paper's identification, the quality of a fit, its scale flags;
- :mod:`.error_model`: the one noise rule, the model-error term, each point's sigma, the score;
- :mod:`.result`: :class:`~.result.FitResult`, the one result of every fit (one curve or several, a
  fit or a rung of a diagnosis's ladder), its score; :mod:`.result_text` its text of each curve;
- :mod:`.hertz`: :func:`fit_hertz`, Hertz fitted as AFM tools (nanite) fit it.
- :mod:`.multistart`: the multistart fitter of any model (each set of effects fitted once);
- :mod:`.starts`: where its fits start (start vectors) and, in the loop, the screen that ranks them;
- :mod:`.rung`: a fitted model's BIC, its residual in words, its covariance by the names reported.
"""

from .curve import MISFIT_LIMIT, quality
from .result import FitResult
from .one_fit import fit, incompressible_limit
from .hertz import fit_hertz
from .identification import (METHODS, NEARLY_INCOMPRESSIBLE_NU, PAPER_TOLERANCE, check_fixed, hertz_modulus, identify,
                       run_method, start_values)
from .surfaces import SIMILARITY_RATIOS, check_inside, default_grid, elastic_core, surface_for, unit_surface_grid

#: the name of a fit's result before :class:`FitResult` was the one result of every fit (kept for imports)
CurveFit = FitResult

__all__ = ["FitResult", "METHODS", "MISFIT_LIMIT", "NEARLY_INCOMPRESSIBLE_NU", "PAPER_TOLERANCE", "SIMILARITY_RATIOS", "CurveFit",
           "check_fixed", "check_inside", "default_grid", "elastic_core", "fit", "fit_hertz", "hertz_modulus", "identify",
           "incompressible_limit",
           "quality", "run_method", "start_values", "surface_for", "unit_surface_grid"]
