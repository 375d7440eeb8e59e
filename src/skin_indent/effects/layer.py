"""``layer``: a bonded top layer over a half-space of another modulus, or over a rigid base.

Parameters: ``thickness_mm`` and ``ratio`` = E_below / E_top (``inf``: a rigid base).
It is fitted on a response surface over the thickness and the compliance
``1 / ratio`` = E_top / E_below, in the coordinate ``log(compliance + 0.1)`` (log F is
nearly linear there, as for springs in series; a rigid base is the node 0).
"""

from __future__ import annotations

import math

from .base import ELASTIC, Effect, EffectParameter, ForwardSpec
from .base import EffectAxis

#: A layer inserted above a fitted one leaves it at least this fraction of its thickness
#: (:meth:`Layer.insert`; the admissible range starts at 10 nm, far below any curve's resolution).
MIN_REST = 0.05


class Layer(Effect):
    name = "layer"
    description = "a bonded top layer over a softer or stiffer half-space, or a rigid base"
    parameters = (
        # from 10 nm (AFM on films and cells, R of a few um) to skin layers
        EffectParameter("thickness_mm", "mm", 1e-5, 20.0, None, True, "thickness of the bonded top layer", 1.0),
        EffectParameter("ratio", "-", 0.02, math.inf, 1.0, True,
                        "modulus of the material below over that of the layer (inf: rigid base)",
                        physical_limit="upper"),  # a rigid base
    )
    stage = ELASTIC
    #: two layers (dermis, hypodermis) over a half-space or a rigid base: ``("layer", "layer")``
    repeatable = True

    def configure(self, spec: ForwardSpec, values: dict) -> None:
        # a layer under the previous ones has the modulus of what was below them
        spec.layers.append((values["thickness_mm"], spec.below))
        spec.below = spec.below * values["ratio"]

    # fitted on a surface over thickness and compliance = 1 / ratio
    @property
    def fit_names(self):
        return ("thickness_mm", "compliance")

    def to_fit(self, values, E_kPa):
        r = values["ratio"]
        return {"thickness_mm": float(values["thickness_mm"]), "compliance": 0.0 if math.isinf(r) else 1.0 / r}

    def from_fit(self, fit, E_kPa):
        c = float(fit["compliance"])
        return {"thickness_mm": float(fit["thickness_mm"]), "ratio": math.inf if c < 1e-6 else 1.0 / c}

    def surface_axes(self, max_depth_mm):
        """Thickness 1.2-17 times the deepest depth (log), compliance in [0, 8].

        The thinnest node is the thinnest layer whose rigid-base node (compliance 0) the FE
        model solves with a margin at every mesh: the sphere then squeezes it to
        ``h/T = 1/1.2 = 0.83`` at the deepest depth, and the model solves layers on a rigid
        base to h/T = 0.91-0.98 (measured: R = 1 mm, T = 0.05-1 mm, nu = 0.3-0.49; coarse
        >= 0.96, medium >= 0.945, fine >= 0.91; the AFM case of R = 27.5 um at h/R = 0.58,
        T = 1.1 depths, solves at every nu node). Thinner than the depth (h/T > 1) is possible
        over a softer or stiffer half-space (solved to h/T = 1.5 over one 8 times stiffer), not
        on a rigid base, whose node every thickness of the surface needs.
        """
        t = tuple(float(f"{max_depth_mm * k:.4g}") for k in (1.2, 1.5, 2.5, 4.0, 6.5, 10.5, 17.0))
        return (EffectAxis("thickness_mm", t, "log"),
                EffectAxis("compliance", (0.0, 0.12, 0.3, 0.65, 1.4, 3.2, 8.0), "log", 0.1))

    def starts(self, data, bounds):
        """Thicknesses 2, 4 and 8 times the deepest depth (else the middle of the range, log; all
        inside the thickness range, which starts at 1.2 depths), a rigid base, a stiffer and a
        softer material below."""
        lo, hi = bounds["thickness_mm"]
        h = float(getattr(data, "max_indentation_mm", math.nan))
        t = [k * h for k in (2.0, 4.0, 8.0)] if math.isfinite(h) and h > 0 else [math.sqrt(lo * hi)]
        t = sorted({float(min(max(v, lo), hi)) for v in t})
        return {"thickness_mm": tuple(t), "compliance": (0.0, 0.5, 4.0)}

    def insert(self, fitted, position, new):
        """A layer inserted above a fitted one takes its thickness from it: the interfaces
        fitted before stay where they were (None if it would leave that layer thinner than
        :data:`MIN_REST` of its thickness, or than the admissible range)."""
        out = [dict(v) for v in fitted]
        if position < len(out):
            rest = out[position]["thickness_mm"] - new["thickness_mm"]
            if rest < max(self.parameters[0].lower, MIN_REST * out[position]["thickness_mm"]):
                return None
            out[position]["thickness_mm"] = rest
        return [*out[:position], dict(new), *out[position:]]
