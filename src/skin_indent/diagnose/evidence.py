"""Evidence beyond the fits: which effects can show in the data, and which measurement
would separate two candidates that explain it about equally well."""

from __future__ import annotations

import functools
import math

import numpy as np

from .data import DiagnosisData

#: chi-square an effect must be able to explain beyond what E and nu absorb to be detectable
DETECTABLE = 10.0

def viscoelastic_visible(data: DiagnosisData) -> str | None:
    """None if rate effects can show, else why not."""
    if data.time_s is None:
        return "the curve has no time column: rate effects cannot be told from elastic ones"
    if data.has("hold") or data.has("retract"):
        return None
    load = data.kind == "approach"
    v = np.diff(data.depth_mm[load]) / np.diff(data.time_s[load])
    v = v[np.isfinite(v) & (v > 0)]
    if v.size > 5 and np.percentile(v, 90) > 1.5 * np.percentile(v, 10):
        return None
    return ("a single constant-speed loading ramp: relaxation during it looks like an elastic nonlinearity; "
            "a hold or an unloading segment would show it")


def adhesion_visible(data: DiagnosisData, noise: float) -> str | None:
    if np.count_nonzero(data.force_mN < -3.0 * noise) >= 3:  # not a stray noise sample
        return None
    if data.has("retract"):
        return "no tensile (negative) force beyond the noise on unloading: no pull-off to explain"
    return "no retract segment and no tensile force: adhesion shows as a pull-off on unloading"


@functools.lru_cache(maxsize=32)
def _full_stick_ratio(nu: float, depth_mm: float, radius_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Depths (mm) and F(full stick) / F(frictionless) of a neo-Hookean half-space (coarse FE, 24 steps)."""
    from ..mechanics.contact import ContactLaw, SphericalIndenter
    from ..mechanics.materials import NeoHooke
    from ..protocol import Protocol
    from ..simulate import simulate

    ramp = Protocol.ramp(depth_mm, 24)
    runs = [simulate(NeoHooke(1.0, nu), SphericalIndenter(radius_mm), depth_mm, protocol=ramp, mesh="coarse",
                     contact=ContactLaw(friction=mu)) for mu in (0.0, 1.0)]
    return runs[0].depth_mm[1:], runs[1].force_mN[1:] / runs[0].force_mN[1:]


def friction_visible(ctx, base) -> tuple[str | None, dict]:
    """Weigh full-stick friction at the fitted nu with two FE runs against what E and nu absorb.

    ``base`` is the best-fitting model of the diagnosis: its nu, its prediction and its
    (E, nu) Jacobian columns.
    """
    nu = float(base.parameters.get("nu", 0.45))
    d = ctx.data
    off = base.parameters.get("offset_mm", 0.0)
    h = d.depth_mm - off
    touch = h > 0
    hmax = float(h[touch].max())
    try:
        depths, ratio_curve = _full_stick_ratio(round(nu, 3), float(f"{hmax:.3g}"), ctx.radius_mm)
    except Exception as exc:  # noqa: BLE001 - reported, not fatal
        return f"the full-stick check did not run ({type(exc).__name__}: {exc})", {}
    ratio = np.interp(h[touch], depths, ratio_curve)
    delta = np.zeros_like(h)
    delta[touch] = base.prediction_mN[touch] * (ratio - 1.0)
    # what refitting E and nu cannot absorb: remove the part along the base Jacobian
    model, x = base.evaluate()
    J = model.jacobian(d.depth_mm, x)[:, :2]
    s = ctx.sigma(base.prediction_mN)
    A = J / s[:, None]
    b = delta / s
    coef, *_ = np.linalg.lstsq(A, b, rcond=None)
    gain = float(np.sum((b - A @ coef) ** 2))
    info = {"full_stick_change_mN": float(np.max(np.abs(delta))), "chi2_gain_after_refit": gain, "nu": nu}
    if gain < DETECTABLE:
        return (f"full stick changes the force by at most {info['full_stick_change_mN']:.2g} mN at nu = {nu:.2f}, "
                f"and refitting E absorbs all but a chi-square of {gain:.2g} (< {DETECTABLE:g})"), info
    return None, info


def suggest_measurement(ctx, a, b) -> str:
    """Which extra measurement separates two fitted candidates, with the predicted difference.

    Candidates are compared on (i) an unloading back to zero at the loading speed,
    (ii) a 30 s hold at the deepest point, both from the surrogate models; and on
    (iii) a sphere of half the radius and (iv) an indentation 1.5 times deeper, both
    by forward FE runs of the two fitted models.
    """
    from ..effects import Model

    d = ctx.data
    noise = ctx.noise_mN
    out = {}
    ea, eb = a.effects[-1], b.effects[-1]
    fe_ok = all(e in ("layer", "stiffening", "offset") for e in (*a.effects, *b.effects))
    if fe_ok:
        def theta(f):
            t = {k: v for k, v in f.parameters.items() if k != "offset_mm"}
            return t

        hmax = ctx.max_depth
        for label, radius, depth in ((f"a sphere of half the radius (R = {ctx.radius_mm / 2:.3g} mm) to the same "
                                      f"depth", ctx.radius_mm / 2, hmax),
                                     (f"an indentation 1.5 times deeper ({1.5 * hmax:.3g} mm)", ctx.radius_mm,
                                      1.5 * hmax)):
            try:
                fa = Model(tuple(e for e in a.effects if e != "offset"), radius).simulate(theta(a), depth,
                                                                                          mesh="coarse")
                fb = Model(tuple(e for e in b.effects if e != "offset"), radius).simulate(theta(b), depth,
                                                                                          mesh="coarse")
                out[label] = float(np.max(np.abs(fa.force_mN - fb.force_mN)))
            except Exception:  # noqa: BLE001 - a measurement we cannot predict is not suggested
                continue
    if "viscoelastic" in (ea, eb) and d.time_s is not None:
        # a hold at the deepest point: the elastic candidate stays flat, the viscoelastic one relaxes
        va, xa = (a if ea == "viscoelastic" else b).evaluate()
        g = (a if ea == "viscoelastic" else b).parameters["g1"]
        peak = float(np.max((a if ea == "viscoelastic" else b).prediction_mN))
        out["a 30 s hold at the deepest point"] = g * peak * (1 - math.exp(-30.0 / max(
            (a if ea == "viscoelastic" else b).parameters["tau1_s"], 1e-9)))
    if not out:
        return "no extra measurement computed here separates them"
    label, diff = max(out.items(), key=lambda kv: kv[1])
    return (f"{label} would separate {ea} from {eb}: the fitted models differ there by up to {diff:.3g} mN, "
            f"{diff / noise:.1f} times the noise")
