"""The vocabulary of physical effects, and models made of a base law plus effects.

The base model is a neo-Hookean half-space (E, nu). Each :class:`Effect` adds
what the simple model misses, with parameters that response surfaces,
inversion and diagnosis take like E and nu. Names are used everywhere (API,
CLI, JSON, reports):

``layer``
    a bonded top layer over a half-space of another modulus, or over a rigid
    base (``ratio = inf``): ``thickness_mm``, ``ratio`` = E_below / E_top.
``stiffening``
    strain stiffening, W = W_NH + C20 (I1b - 3)^2: ``C20_kPa``.
``viscoelastic``
    quasi-linear viscoelasticity with one Prony term: ``g1``, ``tau1_s``.
``friction``
    Coulomb friction between sphere and skin (regularised penalty, stick and
    slip): ``mu``.
``adhesion``
    an attractive traction between sphere and skin: work of adhesion
    ``w_mJ_per_m2`` (mJ/m^2 = 1e-3 mN/mm; its range is
    :data:`ADHESION_RANGE_MM`), giving a pull-off force on unloading.
``offset``
    a shift of the contact point: ``offset_mm`` (a nuisance parameter of fits).

Every effect has an *off* value that gives back the base model exactly. In a
:class:`Model`, ``E_kPa`` is the modulus of the top material and every other
modulus is given relative to it, so the force is exactly proportional to
``E_kPa`` at fixed other parameters: a response surface needs finite-element
runs over the other parameters only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .mechanics.contact import SphericalIndenter
from .mechanics.layers import RIGID, Layer, LayeredSample
from .mechanics.materials import NeoHooke, NeoHookeStiffening, PronyTerm, Viscoelastic


@dataclass(frozen=True)
class EffectParameter:
    """One parameter of an effect.

    Attributes
    ----------
    name : str
        With its unit (``thickness_mm``, ``tau1_s``, ``ratio``...).
    unit : str
    lower, upper : float
        Admissible (closed) range; ``upper`` may be ``inf`` (rigid base).
    off : float or None
        The value that switches the effect off (None: the effect is switched off
        by another parameter, e.g. a layer's thickness does not matter at ratio 1).
    log : bool
        Whether the parameter is naturally sampled on a log scale.
    description : str
    neutral : float or None
        Value used when the parameter does not matter (its effect is off).
    open_bounds : bool
        The range excludes its ends (Poisson's ratio).
    """

    name: str
    unit: str
    lower: float
    upper: float
    off: float | None
    log: bool
    description: str
    neutral: float | None = None
    open_bounds: bool = False

    def contains(self, value: float) -> bool:
        if math.isnan(value):
            return False
        if self.open_bounds:
            return self.lower < value < self.upper
        return self.lower <= value <= self.upper


@dataclass(frozen=True)
class Effect:
    """A physical effect of the vocabulary (see the module docstring)."""

    name: str
    parameters: tuple
    needs_history: bool
    description: str

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    def off_values(self) -> dict[str, float]:
        return {p.name: p.off for p in self.parameters if p.off is not None}


EFFECTS = {
    "layer": Effect("layer", (
        EffectParameter("thickness_mm", "mm", 0.05, 20.0, None, True, "thickness of the bonded top layer", 1.0),
        EffectParameter("ratio", "-", 0.02, math.inf, 1.0, True,
                        "modulus of the material below over that of the layer (inf: rigid base)"),
    ), False, "a bonded top layer over a softer or stiffer half-space, or a rigid base"),
    "stiffening": Effect("stiffening", (
        EffectParameter("C20_kPa", "kPa", 0.0, math.inf, 0.0, False,
                        "Yeoh-type stiffening: W = W_NH + C20 (I1b - 3)^2"),
    ), False, "strain stiffening of the tissue"),
    "viscoelastic": Effect("viscoelastic", (
        EffectParameter("g1", "-", 0.0, 0.95, 0.0, False, "relative modulus of the Prony term"),
        EffectParameter("tau1_s", "s", 1e-3, 1e4, None, True, "relaxation time of the Prony term", 1.0),
    ), True, "rate-dependent (quasi-linear viscoelastic) response"),
    "friction": Effect("friction", (
        EffectParameter("mu", "-", 0.0, 10.0, 0.0, False, "Coulomb friction coefficient (10: full stick)"),
    ), True, "friction between sphere and skin (stick and slip)"),
    "adhesion": Effect("adhesion", (
        EffectParameter("w_mJ_per_m2", "mJ/m2", 0.0, math.inf, 0.0, False, "work of adhesion"),
    ), False, "adhesion between sphere and skin (pull-off on unloading)"),
    "offset": Effect("offset", (
        EffectParameter("offset_mm", "mm", -math.inf, math.inf, 0.0, False,
                        "recorded depth at which contact begins"),
    ), False, "a shifted contact point (depth origin)"),
}

#: range of the adhesive traction law, mm (see :class:`~skin_indent.mechanics.contact.ContactLaw`)
ADHESION_RANGE_MM = 0.06

BASE_PARAMETERS = (
    EffectParameter("E_kPa", "kPa", 0.0, math.inf, None, True, "Young's modulus (of the top material)",
                    open_bounds=True),
    EffectParameter("nu", "-", -1.0, 0.5, None, False, "Poisson's ratio (all materials)", open_bounds=True),
)


def effect(name: str) -> Effect:
    """The effect called ``name``, with a one-line error listing the vocabulary otherwise."""
    try:
        return EFFECTS[name]
    except KeyError:
        raise ValueError(f"unknown effect {name!r}: choose from {', '.join(EFFECTS)}") from None


@dataclass(frozen=True)
class Model:
    """The neo-Hookean half-space plus a set of effects.

    Parameters
    ----------
    effects : tuple of str
        Names from :data:`EFFECTS` (each at most once).
    radius_mm : float
        Sphere radius, mm.

    Examples
    --------
    >>> m = Model(("layer",))
    >>> m.parameter_names
    ('E_kPa', 'nu', 'thickness_mm', 'ratio')
    """

    effects: tuple = ()
    radius_mm: float = 6.22

    def __post_init__(self):
        names = tuple(self.effects)
        for name in names:
            effect(name)
        if len(set(names)) != len(names):
            raise ValueError(f"each effect may appear once, got {names}")
        object.__setattr__(self, "effects", names)
        SphericalIndenter(self.radius_mm)

    @property
    def name(self) -> str:
        return "neo-hooke" + "".join(f"+{e}" for e in self.effects)

    @property
    def parameters(self) -> tuple[EffectParameter, ...]:
        return BASE_PARAMETERS + tuple(p for e in self.effects for p in EFFECTS[e].parameters)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def needs_history(self) -> bool:
        return any(EFFECTS[e].needs_history for e in self.effects)

    def with_effect(self, name: str) -> "Model":
        return Model(self.effects + (name,), self.radius_mm)

    def check(self, theta: dict) -> dict:
        """Complete ``theta`` with off values and check every parameter against its range."""
        out = {}
        for p in self.parameters:
            if p.name in theta:
                value = float(theta[p.name])
            elif p.off is not None:
                value = p.off
            elif p.neutral is not None:
                value = p.neutral  # does not matter while its effect is off
            else:
                raise ValueError(f"model {self.name} needs a value for {p.name}")
            if not p.contains(value):
                brackets = "()" if p.open_bounds else "[]"
                raise ValueError(f"{p.name} = {value:g} is outside {brackets[0]}{p.lower:g}, {p.upper:g}{brackets[1]} "
                                 f"({p.description})")
            out[p.name] = value
        unknown = set(theta) - set(out)
        if unknown:
            raise ValueError(f"model {self.name} has no parameter(s) {sorted(unknown)}")
        return out

    def sample(self, theta: dict):
        """The material or layered sample of the parameters ``theta`` (mm, kPa, s)."""
        t = self.check(theta)
        E, nu = t["E_kPa"], t["nu"]

        def law(modulus):
            c20 = t.get("C20_kPa", 0.0) * modulus / E  # stiffening scales with the local modulus
            base = NeoHookeStiffening(modulus, nu, c20) if c20 > 0 else NeoHooke(modulus, nu)
            if t.get("g1", 0.0) > 0:
                return Viscoelastic(base, (PronyTerm(t["g1"], t["tau1_s"]),))
            return base

        if "layer" in self.effects and t["ratio"] != 1.0:
            below = RIGID if math.isinf(t["ratio"]) else law(E * t["ratio"])
            return LayeredSample((Layer(t["thickness_mm"], law(E)),), below)
        return law(E)

    def contact(self, theta: dict):
        """The :class:`~skin_indent.mechanics.contact.ContactLaw` of ``theta`` (frictionless, non-adhesive by default)."""
        from .mechanics.contact import ContactLaw

        t = self.check(theta)
        return ContactLaw(friction=t.get("mu", 0.0), adhesion_mJ_per_m2=t.get("w_mJ_per_m2", 0.0),
                          adhesion_range_mm=ADHESION_RANGE_MM)

    def simulate(self, theta: dict, depth_mm=None, *, protocol=None, mesh="medium", **kwargs):
        """Force-depth curve of the parameters ``theta`` (see :func:`skin_indent.simulate.simulate`).

        History-dependent parameters (viscoelastic, friction, adhesion) need
        ``protocol``; the offset is applied to the recorded depths.
        """
        from .simulate import simulate

        t = self.check(theta)
        sample = self.sample(t)
        contact = self.contact(t)
        if protocol is None and not (sample.path_independent and contact.path_independent):
            raise ValueError(f"model {self.name} with these parameters needs a protocol (time and depth)")
        return simulate(sample, SphericalIndenter(self.radius_mm), depth_mm if protocol is None else 0.6,
                        protocol=protocol, offset_mm=t.get("offset_mm", 0.0), mesh=mesh,
                        contact=kwargs.pop("contact", contact), **kwargs)

    def unit_parameters(self, theta: dict) -> dict:
        """The parameters of the unit-modulus curve: moduli relative to E (C20 / E, w / E)."""
        t = self.check(theta)
        out = {k: v for k, v in t.items() if k != "E_kPa"}
        for k in ("C20_kPa", "w_mJ_per_m2"):
            if k in out:
                out[k] = out[k] / t["E_kPa"]
        return out
