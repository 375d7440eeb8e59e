"""From a recorded curve to material parameters.

- :mod:`.surfaces`: which response surface serves a curve (cached or built);
- :mod:`.identification`: the paper's identification step on a surface (Hertz start, checks,
  the methods by name);
- :mod:`.one_fit`: :func:`fit`, the one fit of a recorded curve (or several of one sample): the
  model's fit by the multistart fitter (``fit(m)`` is ``fit(m, model="neo-hooke")``), the paper's
  identification an option of it;
- :mod:`.curve`: :class:`CurveFit`, the result of one curve's fit, and the paper's identification;
- :mod:`.error_model`: the one noise rule, the model-error term, each point's sigma, the score;
- :mod:`.result`: what every fit's result reports (:class:`~.result.FitResult`), its score;
- :mod:`.hertz`: :func:`fit_hertz`, Hertz fitted as AFM tools (nanite) fit it.
- :mod:`.multistart`: the multistart fitter of any model (each set of effects fitted once);
- :mod:`.starts`: where its fits start (start vectors) and, in the loop, the screen that ranks them;
- :mod:`.rung`: one fitted model, :class:`~.rung.Rung`, its BIC and its residual in words.
"""

from .curve import MISFIT_LIMIT, CurveFit, quality
from .one_fit import fit, incompressible_limit
from .hertz import fit_hertz
from .identification import (METHODS, NEARLY_INCOMPRESSIBLE_NU, PAPER_TOLERANCE, check_fixed, hertz_modulus, identify,
                       run_method, start_values)
from .surfaces import SIMILARITY_RATIOS, check_inside, default_grid, elastic_core, surface_for, unit_surface_grid

__all__ = ["METHODS", "MISFIT_LIMIT", "NEARLY_INCOMPRESSIBLE_NU", "PAPER_TOLERANCE", "SIMILARITY_RATIOS", "CurveFit",
           "check_fixed", "check_inside", "default_grid", "elastic_core", "fit", "fit_hertz", "hertz_modulus", "identify",
           "incompressible_limit",
           "quality", "run_method", "start_values", "surface_for", "unit_surface_grid"]
