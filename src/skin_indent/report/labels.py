"""Words and line styles for figures: what a reader sees instead of the code's identifiers.

- :func:`parameter_label`: a parameter name as the results report it (``E_kPa``, ``nu``,
  ``thickness2_mm``, ``w_mJ_per_m2``) as an axis label: ``E (kPa)``, ``ν``,
  ``thickness 2 (mm)``, ``w (mJ/m²)``;
- :func:`model_label`: a model name (``neo-hooke+layer``) as a reader writes it
  (``neo-Hooke + layer``);
- :func:`line_styles`: line styles, widths and staggered markers that keep curves which
  coincide apart (the later ones dashed, dotted and thinner, drawn on top);
- :func:`same_curve_as`: for each curve, the earlier curve it cannot be told apart from
  on the figure, so that a legend can say "same curve as ...".

Pure Python and numpy: nothing here imports matplotlib.
"""

from __future__ import annotations

import re

import numpy as np

__all__ = ["line_styles", "model_label", "parameter_label", "same_curve_as"]

#: unit suffixes of parameter names -> the unit as printed
_UNITS = {"kPa": "kPa", "Pa": "Pa", "MPa": "MPa", "mm": "mm", "um": "µm", "nm": "nm", "mN": "mN", "uN": "µN",
          "nN": "nN", "N": "N", "s": "s", "mJ_per_m2": "mJ/m²", "mN_per_mm": "mN/mm"}
#: parameter stems written as Greek letters (Poisson's ratio, friction coefficient, relaxation time)
_GREEK = {"nu": "ν", "mu": "μ", "tau": "τ", "sigma": "σ", "lambda": "λ"}
#: stems written with subscripts
_SUBSCRIPT = {"C20": "C₂₀", "C10": "C₁₀", "g": "g", "E": "E"}
_SUBSCRIPT_DIGITS = str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")
#: model names -> as written in prose
_MODELS = {"neo-hooke": "neo-Hooke"}


def parameter_label(name: str) -> str:
    """The axis label of a parameter: symbol, then its unit in brackets.

    Parameters
    ----------
    name : str
        As the results report it: ``E_kPa``, ``nu``, ``tau1_s``, ``thickness2_mm``,
        ``w_mJ_per_m2``, ``contact_point_mm``; any other name is returned with its
        underscores as spaces.

    Returns
    -------
    str
        ``E (kPa)``, ``ν``, ``τ₁ (s)``, ``thickness 2 (mm)``, ``w (mJ/m²)``,
        ``contact point (mm)``.

    Examples
    --------
    >>> parameter_label("E_kPa"), parameter_label("nu"), parameter_label("tau1_s")
    ('E (kPa)', 'ν', 'τ₁ (s)')
    """
    stem, unit = name, None
    for suffix in sorted(_UNITS, key=len, reverse=True):  # the longest suffix first (mJ_per_m2 before m2)
        if name.endswith("_" + suffix) and len(name) > len(suffix) + 1:
            stem, unit = name[: -len(suffix) - 1], _UNITS[suffix]
            break
    match = re.fullmatch(r"([A-Za-z_]+?)(\d*)", stem)
    if match:
        letters, number = match.groups()
        if letters in _GREEK:
            stem = _GREEK[letters] + number.translate(_SUBSCRIPT_DIGITS)
        elif stem in _SUBSCRIPT:
            stem = _SUBSCRIPT[stem]
        elif number and len(letters) == 1:  # g1 -> g₁
            stem = letters + number.translate(_SUBSCRIPT_DIGITS)
        elif number:  # thickness2 -> thickness 2 (the second layer)
            stem = f"{letters.replace('_', ' ')} {number}"
        else:
            stem = letters.replace("_", " ")
    return f"{stem} ({unit})" if unit else stem


def model_label(model: str) -> str:
    """A model's name as a reader writes it: ``neo-hooke+layer+layer`` -> ``neo-Hooke + layer + layer``.

    Parameters
    ----------
    model : str
        ``+``-joined: the elastic core, then its effects in order.

    Returns
    -------
    str
    """
    return " + ".join(_MODELS.get(part, part) for part in model.split("+"))


def line_styles(n: int, points: int) -> list[dict]:
    """Matplotlib ``plot`` keywords that keep ``n`` curves of ``points`` points apart.

    The first curve is a thick solid line; the later ones are dashed, dotted,
    dash-dotted and thinner, each with a few markers of its own shape at positions
    staggered between curves, so that curves which coincide all stay visible (draw
    them in order: the later ones on top).

    Parameters
    ----------
    n : int
        Number of curves.
    points : int
        Number of points of each curve (for where the markers go).

    Returns
    -------
    list of dict
        ``linestyle``, ``linewidth``, ``marker``, ``markevery``, ``markersize`` per curve.
    """
    dashes = ("-", "--", ":", "-.", (0, (5, 1, 1, 1)), (0, (1, 2)))
    markers = (None, "s", "^", "D", "v", "o")
    every = max(1, points // 8)
    styles = []
    for k in range(n):
        marker = markers[k % len(markers)]
        styles.append({"linestyle": dashes[k % len(dashes)], "linewidth": max(2.6 - 0.5 * k, 1.0),
                       "marker": marker, "markersize": 5,
                       "markevery": (min(k * every // max(n, 1), points - 1) if points else 0, every)
                       if marker else None})
    return styles


def same_curve_as(curves, names, rtol: float = 2e-3) -> dict:
    """For each curve, the first earlier curve it cannot be told apart from on a figure.

    Parameters
    ----------
    curves : sequence of array_like
        Curves at the same abscissae (mN).
    names : sequence of str
        Their legend names, in the same order.
    rtol : float
        Curves whose largest difference is below ``rtol`` times the largest |value|
        of all curves are the same curve on the figure (0.2 %: less than a line width).

    Returns
    -------
    dict
        ``name -> name of the earlier identical curve``; curves unlike every earlier one
        are absent.
    """
    arrays = [np.asarray(c, dtype=float) for c in curves]
    finite = [np.abs(a[np.isfinite(a)]) for a in arrays]
    scale = max((float(f.max()) for f in finite if f.size), default=0.0)
    same = {}
    for j, b in enumerate(arrays):
        for i in range(j):
            a = arrays[i]
            if a.shape == b.shape and np.all(np.abs(a - b) <= rtol * scale):
                same[names[j]] = same.get(names[i], names[i])
                break
    return same
