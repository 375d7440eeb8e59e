"""What a diagnosis is told and what the scale holds: the values held and priors checked against the
models it fits (:func:`check_known`), nu held at AFM scale as ``fit`` holds it (:func:`scale_conventions`)
and the optima of another diagnosis as known starts (:func:`known_starts`)."""

from __future__ import annotations

from ..effects import BASE_PARAMETERS, instances, numbered
from ..measurement.scale import afm_scale
from ..fitting.surfaces import EFFECT_NU
from ..models.joint import split_name


def known_starts(starts) -> dict:
    """``{effects: fit parameters}`` of the rungs of a :class:`Diagnosis` (or of several), or a dict as given."""
    if starts is None or isinstance(starts, dict):
        return dict(starts or {})
    out = {}
    for d in starts if isinstance(starts, (list, tuple)) else [starts]:
        for f in [*d.ladder, *d.alternatives, *(g for s in d.steps for g in s.ranking)]:
            if f.fit_parameters:
                out.setdefault(tuple(f.effects), dict(f.fit_parameters))
    return out


#: Poisson's ratio every model of a diagnosis holds at AFM scale: the nearly incompressible end that
#: all its surfaces cover (the field holds nu = 0.5; the finite-element law needs nu < 0.5)
AFM_NU = max(EFFECT_NU)


def scale_conventions(curves, fixed, priors, free=()) -> tuple[dict | None, list[str]]:
    """What the scale of ``curves`` holds, as ``fit`` holds it: ``(fixed, notes)``.

    At AFM scale (every sphere below 0.5 mm: :func:`~skin_indent.measurement.scale.afm_scale`) the
    field holds nu = 0.5; a diagnosis holds it at :data:`AFM_NU` = 0.49, the nearly incompressible end
    of its surfaces, unless nu is held or given a prior already or ``free`` names it. A curve determines
    E* = E / (1 - nu^2) there, so E at nu = 0.5 is 0.75 / (1 - 0.49^2) = 0.987 of the E reported.
    """
    free = tuple(free or ())
    if set(free) - {"nu"}:
        raise ValueError(f"free takes nu (held at {AFM_NU:g} by default at AFM scale), got {', '.join(free)}")
    if "nu" in free and "nu" in (fixed or {}):
        raise ValueError(f"nu is both held (at {fixed['nu']:g}) and freed: give one of them")
    if ("nu" in free or "nu" in (fixed or {}) or "nu" in (priors or {})
            or not all(afm_scale(c.radius_mm) for c in curves)):
        return fixed, []
    note = (f"nu = {AFM_NU:g} held at AFM scale (a sphere of AFM or cell size), the nearly incompressible end of the "
            "surfaces, as the field holds nu = 0.5: E at nu = 0.5 is "
            f"{100 * (1 - 0.75 / (1 - AFM_NU**2)):.1f} % lower; --free nu fits it")
    return {**(fixed or {}), "nu": AFM_NU}, [note]


def check_known(fixed, priors, effects, n_curves: int) -> None:
    """Every name held (``fixed``) or given a prior is a parameter of the base model or of one of the
    ``effects`` (or a curve's own parameter, ``offset_mm[2]``): one line naming the vocabulary otherwise."""
    names = {p.name for p in BASE_PARAMETERS}
    for e in instances(tuple(dict.fromkeys(effects))):
        for k in range(1, 4):  # up to a third occurrence of a repeatable effect (thickness3_mm)
            names |= {numbered(p.name, k) if k > 1 else p.name for p in e.parameters}
            if not e.repeatable:
                break
    for name in (*(fixed or {}), *(priors or {})):
        base, curve = split_name(name)
        if base not in names or (curve is not None and curve >= n_curves):
            raise ValueError(f"{name}: not a parameter of any model this diagnosis fits (parameters: "
                             f"{', '.join(sorted(names))}" + ("; a curve's own as offset_mm[2]" if n_curves > 1
                                                               else "") + ")")
