"""``viscoelastic_powerlaw``: power-law relaxation of cells and tissues, E(t) = E (t / 1 s)^-beta (``beta``).

Cell rheology follows a power law over decades of time, beta about 0.1-0.4 (Fabry et al.,
*Phys. Rev. Lett.* 87 (2001) 148102; Efremov et al., *Sci. Rep.* 7 (2017) 1541, whose ViscoIndent
offers the power law beside the standard linear solid). It is the other relaxation kernel of the
vocabulary beside ``viscoelastic`` (one Prony term): both are of the kind ``relaxation``, a model
has one of them, and the diagnosis ranks them against each other by BIC, so the evidence says
which kernel the curve shows.

With this effect ``E_kPa`` is the relaxation modulus at t0 = 1 s (the convention of cell
rheology), not the instantaneous one; the kernel is
:class:`~skin_indent.effects.hereditary.PowerLawKernel`, cut at 10 us so that the instantaneous
modulus is finite (see :mod:`skin_indent.effects.hereditary`).

Fitted: the Lee-Radok / Ting hereditary integral over the elastic force
(:mod:`skin_indent.effects.hereditary`), exact at small strain (Ting's closed form with the Beta
function, :func:`~skin_indent.mechanics.analytic.ting_power_law_force`) and the QLV approximation at large
strain: no extra finite-element runs. Forward: every material relaxes with a Prony series fitted
to the kernel over [0, 1e4 s] (:func:`~skin_indent.mechanics.materials.viscoelastic.power_law_prony`,
21 terms, within 2.4e-4 of the kernel at beta = 0.3), and the instantaneous modulus is psi(0) E.
"""

from __future__ import annotations

from .base import HISTORY, EffectParameter, Evaluation, ForwardSpec
from .hereditary import PowerLawKernel, hereditary_force, log_lags, relaxation_weights
from .viscoelastic import Viscoelastic

#: the largest exponent a fit tries (cells: 0.1-0.4; 0.8 is nearly a fluid)
BETA_MAX = 0.8


class PowerLaw(Viscoelastic):
    """Power-law relaxation (module docstring); visible where ``viscoelastic`` is (a hold, an
    unloading segment, or ramps at speeds that differ by more than 1.5 times)."""

    name = "viscoelastic_powerlaw"
    description = "power-law relaxation E(t) = E (t / 1 s)^-beta (E_kPa: the modulus at 1 s)"
    parameters = (
        EffectParameter("beta", "-", 0.0, 0.95, 0.0, False, "exponent of the power-law relaxation"),
    )
    stage = HISTORY
    needs_history = True
    kind = "relaxation"

    def configure(self, spec: ForwardSpec, values: dict) -> None:
        from ..mechanics.materials.viscoelastic import power_law_prony

        beta = float(values["beta"])
        if beta <= 0:
            return
        if spec.prony:
            raise ValueError("a model has one relaxation kernel: powerlaw cannot join another Prony series")
        instantaneous, terms, _ = power_law_prony(beta)
        spec.prony.extend((t.g, t.tau_s) for t in terms)
        spec.instantaneous *= instantaneous

    def fit_bounds(self, data, reach_mm=float("inf")):
        """beta in [0, :data:`BETA_MAX`] (the curve needs its times)."""
        if data.time_s is None:
            raise ValueError("a power-law relaxation needs the measurement's time_s")
        return {"beta": (0.0, BETA_MAX)}

    def starts(self, data, bounds):
        return {"beta": (0.1, 0.3)}

    def apply(self, ev: Evaluation, fit: dict) -> None:
        beta = float(fit["beta"])
        if beta <= 0:
            return  # elastic
        weights = ev.cache.setdefault("power_law_weights", {})
        if beta not in weights:
            if len(weights) > 64:
                weights.clear()
            if "power_law_log_lags" not in ev.cache:  # shared by every exponent (the times do not change)
                ev.cache["power_law_log_lags"] = log_lags(ev.time_s)
            weights[beta] = relaxation_weights(ev.time_s, PowerLawKernel(beta), log_lags=ev.cache["power_law_log_lags"])
        ev.force_mN = hereditary_force(ev.time_s, ev.h_mm, ev.force_mN, PowerLawKernel(beta), weights=weights[beta])
