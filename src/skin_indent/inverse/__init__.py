"""Identification of skin parameters from sphere-indentation force-depth curves.

Every method takes a forward model implementing :class:`ForceModel`
(``parameter_names``, ``bounds``, ``force(depth_mm, theta)``,
``jacobian(depth_mm, theta)``), the measured curve (depth in mm, force in mN) and
start values, honours fixed parameters, keeps theta inside the model's box, and
returns an :class:`IdentificationResult`.

- :func:`fit_ekf_paper`: the extended Kalman filter with global stabilization of
  Delalleau et al. (2006), faithful (hundreds of sweeps).
- :func:`fit_ekf`: a well-conditioned EKF (whitened (log E*, nu) state), a few sweeps.
- :func:`fit_least_squares`: bounded Gauss-Newton/trust-region (scipy TRF).
- :func:`estimate_noise`: the noise level of a curve from the data alone.
- :func:`profile`, :func:`hertz_equivalence`: is nu identifiable, beyond E*?
- :func:`run_blind_tests`, :func:`format_table`: the paper's Tables 1-2.
"""

from ._problem import ForceModel
from .identifiability import HertzEquivalence, Profile, hertz_equivalence, profile
from .kalman import fit_ekf
from .kalman_paper import PAPER_MEASUREMENT_STD_MN, PAPER_P0_STD, fit_ekf_paper
from .least_squares import fit_least_squares
from .noise import estimate_noise
from .parameters import Parameter, ParameterSet
from .result import IdentificationResult, information_criteria

__all__ = [
    "ForceModel",
    "Parameter",
    "ParameterSet",
    "IdentificationResult",
    "information_criteria",
    "fit_ekf_paper",
    "fit_ekf",
    "fit_least_squares",
    "estimate_noise",
    "profile",
    "Profile",
    "hertz_equivalence",
    "HertzEquivalence",
    "run_blind_tests",
    "format_table",
    "blind_test_cases",
    "PAPER_TABLE_1",
    "PAPER_TABLE_2",
    "PAPER_P0_STD",
    "PAPER_MEASUREMENT_STD_MN",
]

_LAZY = {"run_blind_tests", "format_table", "blind_test_cases", "PAPER_TABLE_1", "PAPER_TABLE_2"}


def __dir__():
    """Every name of ``__all__``, the lazy ones too: what completion offers after ``inverse.``."""
    return sorted({*globals(), *__all__})


def __getattr__(name):
    # blind_tests is also a script (python -m skin_indent.inverse.blind_tests): import it lazily
    # so that running it does not find it pre-imported.
    if name in _LAZY:
        from . import blind_tests

        return getattr(blind_tests, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
