"""Hertz's sphere fitted as AFM tools fit it, to compare numbers with them (nanite's convention).

:func:`fit_hertz` fits ``F = b + 4/3 E* sqrt(R) (d - d_c)^1.5`` (zero force before the
contact point ``d_c``) to the whole approach segment, after subtracting the flat
pre-contact baseline, with the residual force offset ``b`` and the contact point fitted
jointly and every point weighted equally: the "unweighted" Hertz fit of nanite
(``hertz_para``, ``weight_cp=False``, baseline free). ``tests/test_instrument_files.py``
compares it with nanite's numbers on the afmformats test curves.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from ..effects import CONTACT_POINT
from ..effects.baseline import ForceBaseline
from ..measurement import PreparedCurve, prepare
from ..models import ComposedModel, HertzModel
from .identification import hertz_modulus, run_method


def fit_hertz(data, *, nu: float = 0.5) -> dict:
    """Hertz fit of a recorded curve over its whole approach (see the module docstring).

    Parameters
    ----------
    data : Measurement or PreparedCurve
        A curve recorded from before contact (its radius with it, or prepared).
    nu : float
        Poisson's ratio for E = E* (1 - nu^2).

    Returns
    -------
    dict
        ``E_kPa``, ``E_star_kPa`` (and their standard errors ``*_std``),
        ``contact_point_mm`` (recorded depth) with its standard error, ``baseline_mN`` (the
        flat line subtracted plus the fitted offset), ``rms_mN``, ``n_points``.
    """
    prepared = data if isinstance(data, PreparedCurve) else prepare(data)
    if prepared.contact_mode != "fit":
        raise ValueError(f"{prepared.source}: the curve has no pre-contact part to fit a contact point in")
    m = prepared.measurement
    approach = m.loading().require_monotone_loading() if m.has_time else m.require_monotone_loading()
    flat = prepared.baseline_fitted.flat() if prepared.baseline_fitted is not None else None
    offset = 0.0 if flat is None else float(flat.offset_mN)
    whole = dataclasses.replace(prepared, depth_mm=approach.depth_mm, force_mN=approach.force_mN - offset,
                                time_s=approach.time_s, kind=np.full(approach.n_points, "approach"))
    h, F = prepared.loading()
    e0 = hertz_modulus(h, F, prepared.radius_mm)
    model = ComposedModel(HertzModel(prepared.radius_mm, (e0 * 1e-3, e0 * 1e3)), (CONTACT_POINT, ForceBaseline()), whole)
    r = run_method(model, whole.depth_mm, whole.force_mN, np.array([e0, prepared.contact_guess_mm, 0.0]), "lsq")
    e_star, sd = r.parameters["E_star_kPa"], r.std["E_star_kPa"]
    return {"E_kPa": e_star * (1 - nu**2), "E_kPa_std": sd * (1 - nu**2), "E_star_kPa": e_star,
            "E_star_kPa_std": sd, "nu": nu, "contact_point_mm": r.parameters["offset_mm"],
            "contact_point_mm_std": r.std["offset_mm"], "baseline_mN": offset + r.parameters["baseline_mN"],
            "rms_mN": r.rms_mN, "n_points": r.n_points, "success": r.success}
