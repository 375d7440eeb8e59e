"""``friction``: Coulomb friction between sphere and skin (regularised penalty, stick and slip), ``mu``.

Forward: the finite-element contact law (:class:`~skin_indent.mechanics.contact_law.ContactLaw`),
history dependent. Not fitted: diagnosis weighs it (:meth:`Friction.weigh`) by two
coarse finite-element runs at the best fit's nu, frictionless and at full stick,
against what refitting E and nu absorbs.
"""

from __future__ import annotations

import functools
import hashlib
import json
import zipfile
from pathlib import Path

import numpy as np

from .base import WEIGHED, Effect, EffectParameter, ForwardSpec
from ..measurement.scale import Quantity, UnitText
from ..mechanics.protocol import Protocol
from ..response_surface import default_cache_dir
from ..response_surface import default_settings
from ..runtime.atomic import atomic_write

#: chi-square full stick must be able to add beyond what E and nu absorb to be detectable
DETECTABLE = 10.0


@functools.lru_cache(maxsize=32)
def _full_stick_runs(nu: float, depth_mm: float, radius_mm: float) -> tuple[np.ndarray, np.ndarray]:
    from ..simulate import simulate
    from ..mechanics.contact_law import ContactLaw, SphericalIndenter
    from ..mechanics.materials import NeoHooke

    ramp = Protocol.ramp(depth_mm, 24)
    runs = [simulate(NeoHooke(1.0, nu), SphericalIndenter(radius_mm), depth_mm, protocol=ramp, mesh="coarse",
                     contact=ContactLaw(friction=mu)) for mu in (0.0, 1.0)]
    return runs[0].depth_mm[1:], runs[1].force_mN[1:] / runs[0].force_mN[1:]


def full_stick_ratio(nu: float, depth_mm: float, radius_mm: float,
                     cache_dir=None) -> tuple[np.ndarray, np.ndarray]:
    """Depths (mm) and F(full stick) / F(frictionless) of a neo-Hookean half-space (coarse FE, 24 steps).

    Two runs (about 3 s each, the frictional one the slower). With ``cache_dir`` the result
    is kept in its ``checks`` folder, keyed by the arguments and the forward model's code
    version (as the surfaces are), so a second diagnosis of the same curve does not rerun them.
    """
    if cache_dir is None:
        return _full_stick_runs(nu, depth_mm, radius_mm)
    key = json.dumps({"check": "full-stick ratio", "nu": nu, "depth_mm": depth_mm, "radius_mm": radius_mm,
                      "code_version": default_settings(radius_mm, "coarse")["code_version"]}, sort_keys=True)
    path = Path(cache_dir) / "checks" / f"{hashlib.sha256(key.encode()).hexdigest()[:24]}.npz"
    try:
        with np.load(path) as z:
            if str(z["key"]) == key:
                return z["depth_mm"], z["ratio"]
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):  # not there yet, or damaged: made again
        pass
    depths, ratio = _full_stick_runs(nu, depth_mm, radius_mm)
    try:
        atomic_write(path, lambda fh: np.savez(fh, key=np.array(key), depth_mm=depths, ratio=ratio))
    except OSError:  # a read-only cache: the check still stands
        pass
    return depths, ratio


def _cache_dir(diagnosis):
    """The run cache of the diagnosis' context (None: kept in memory only)."""
    context = getattr(diagnosis, "context", None)
    if context is None:
        return None

    return context.cache_dir if context.cache_dir is not None else default_cache_dir()


class Friction(Effect):
    name = "friction"
    description = "friction between sphere and skin (stick and slip)"
    parameters = (EffectParameter("mu", "-", 0.0, 10.0, 0.0, False, "Coulomb friction coefficient (10: full stick)"),)
    stage = WEIGHED
    needs_history = True

    def configure(self, spec: ForwardSpec, values: dict) -> None:
        spec.contact["friction"] = values["mu"]

    def weigh(self, diagnosis, best) -> str:
        """Full stick at the best fit's nu against what refitting E and nu absorbs, in words.

        ``diagnosis`` gives the prepared data, the radius and the error model
        (``sigma(force)``); ``best`` is the best-fitting model (its parameters, prediction
        and ``model``/``x`` for the (E, nu) Jacobian columns). The largest change of the
        force (mN) is a :class:`~skin_indent.measurement.scale.UnitText` field: the text reads
        in the units of the curve's scale.
        """
        nu = float(best.parameters.get("nu", 0.45))
        d = diagnosis.data
        delta = np.zeros(d.n)
        parts = diagnosis.parts(best) if hasattr(diagnosis, "parts") else [(0, d, None, slice(0, d.n),
                                                                           best.parameters)]
        for _, curve, _, sl, params in parts:  # each curve of a sample with its own sphere and contact point
            h = curve.depth_mm - params.get("offset_mm", 0.0)
            touch = h > 0
            hmax = float(h[touch].max())
            try:
                depths, ratio_curve = full_stick_ratio(round(nu, 3), float(f"{hmax:.3g}"), curve.radius_mm,
                                                       cache_dir=_cache_dir(diagnosis))
            except Exception as exc:  # noqa: BLE001 - reported, not fatal
                return f"the full-stick check did not run ({type(exc).__name__}: {exc})"
            part = np.zeros_like(h)
            part[touch] = best.prediction_mN[sl][touch] * (np.interp(h[touch], depths, ratio_curve) - 1.0)
            delta[sl] = part
        J = best.bound_model.jacobian(d.depth_mm, best.x)[:, :2]  # what refitting E and nu cannot absorb
        s = diagnosis.sigma(best.prediction_mN)
        A, b = J / s[:, None], delta / s
        coef, *_ = np.linalg.lstsq(A, b, rcond=None)
        gain = float(np.sum((b - A @ coef) ** 2))
        change = float(np.max(np.abs(delta)))
        if gain < DETECTABLE:
            return UnitText("full stick changes the force by at most {change:.2g} at nu = {nu:.2f}, and refitting E "
                            "absorbs all but a chi-square of {gain:.2g} (< {detectable:g})",
                            change=Quantity(change, "mN"), nu=nu, gain=gain, detectable=DETECTABLE)
        return (f"full stick could change this curve beyond the noise (chi-square {gain:.3g} after refitting E and "
                f"nu, at nu = {nu:.2f}), but no friction model is fitted yet")
