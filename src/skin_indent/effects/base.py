"""What an effect is: its parameters, how it enters the forward model and the fits.

An :class:`Effect` is one physical mechanism that a homogeneous neo-Hookean
half-space (E, nu) misses. It holds everything about itself, so that the forward
model (:class:`~skin_indent.effects.Model`), the response surfaces, the fits and the
diagnosis ask the effect instead of comparing names:

- **parameters** (:class:`EffectParameter`): name with unit, admissible range, the
  value that switches the effect off;
- **the forward model**: :meth:`Effect.configure` sets its part of a
  :class:`ForwardSpec` (the constitutive law, the layers, the contact law, the
  contact-point offset) from which the finite-element sample is built;
- **the fitted model**: its ``stage`` says where it acts on a fitted force curve
  (:data:`ELASTIC`: an axis of a response surface, :meth:`Effect.surface_axes` and
  :meth:`Effect.unit_values`; :data:`DEPTH`: it moves the depth; :data:`HISTORY` and
  :data:`FORCE`: it acts on the force, :meth:`Effect.apply`; :data:`WEIGHED`: not
  fitted, its influence is weighed by :meth:`Effect.weigh`), the coordinates in which
  it is fitted (:meth:`Effect.to_fit`, :meth:`Effect.from_fit`), their bounds and start
  values for a given curve (:meth:`Effect.fit_bounds`, :meth:`Effect.starts`);
- **evidence**: :meth:`Effect.visible` says whether it can show in a measurement at
  all, and why not.

A new effect is a subclass in a module of its own, registered with
:func:`~skin_indent.effects.register`; nothing else changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: stages of a fitted force model, in the order they act
DEPTH, ELASTIC, HISTORY, FORCE, WEIGHED = "depth", "elastic", "history", "force", "weighed"
STAGE_ORDER = (DEPTH, ELASTIC, HISTORY, FORCE)


@dataclass(frozen=True)
class EffectParameter:
    """One parameter of an effect (or of the base model).

    Attributes
    ----------
    name : str
        With its unit (``thickness_mm``, ``tau1_s``, ``ratio``...).
    unit : str
    lower, upper : float
        Admissible (closed) range; ``upper`` may be ``inf`` (rigid base).
    off : float or None
        The value that switches the effect off (None: the effect is switched off by
        another parameter, e.g. a layer's thickness does not matter at ratio 1).
    log : bool
        Whether the parameter is naturally sampled on a log scale.
    description : str
    neutral : float or None
        Value used when the parameter does not matter (its effect is off).
    open_bounds : bool
        The range excludes its ends (Poisson's ratio).
    physical_limit : {"lower", "upper"} or None
        The end of the range that is a physical limit, which a fit may rightly reach (or
        approach as far as its range goes): a rigid base (a layer's ``ratio`` at ``inf``),
        a nearly incompressible material (``nu`` towards 0.5). A fit that stops at a face
        of its range on that side has found the limit, not failed. None: neither end.
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
    physical_limit: str | None = None

    def __post_init__(self):
        if self.physical_limit not in (None, "lower", "upper"):
            raise ValueError(f"{self.name}: physical_limit must be 'lower', 'upper' or None, "
                             f"got {self.physical_limit!r}")

    def contains(self, value: float) -> bool:
        if math.isnan(value):
            return False
        if self.open_bounds:
            return self.lower < value < self.upper
        return self.lower <= value <= self.upper

    def check(self, value: float) -> float:
        """``value`` as a float, or a one-line error naming the range."""
        value = float(value)
        if not self.contains(value):
            brackets = "()" if self.open_bounds else "[]"
            raise ValueError(f"{self.name} = {value:g} is outside {brackets[0]}{self.lower:g}, {self.upper:g}"
                             f"{brackets[1]} ({self.description})")
        return value


BASE_PARAMETERS = (
    EffectParameter("E_kPa", "kPa", 0.0, math.inf, None, True, "Young's modulus (of the top material)",
                    open_bounds=True),
    EffectParameter("nu", "-", -1.0, 0.5, None, False, "Poisson's ratio (all materials)", open_bounds=True,
                    physical_limit="upper"),  # skin is nearly incompressible: nu -> 0.5
)


@dataclass
class ForwardSpec:
    """What the finite-element model is made of; effects fill it in (:meth:`Effect.configure`).

    Moduli are relative to ``E_kPa`` (the top material), so the force is exactly
    proportional to ``E_kPa`` at fixed other parameters.

    Attributes
    ----------
    E_kPa, nu : float
        The top material.
    C20_over_E : float
        Yeoh-type stiffening of every material, relative to its modulus.
    prony : list of (float, float)
        Prony terms (g, tau_s) of every material.
    layers : list of (float, float)
        Bonded layers as (thickness_mm, modulus relative to the top material), top
        first (the first one has relative modulus 1).
    below : float
        Modulus of the half-space below the layers relative to the top material
        (``inf``: a rigid base).
    contact : dict
        Keywords of :class:`~skin_indent.mechanics.contact_law.ContactLaw`.
    offset_mm : float
        Recorded depth at which contact begins.
    instantaneous : float
        The instantaneous modulus of every material relative to its modulus (1; a power-law
        relaxation, whose E_kPa is the modulus at 1 s, sets it to psi(0) of its Prony series).
    """

    E_kPa: float
    nu: float
    C20_over_E: float = 0.0
    prony: list = field(default_factory=list)
    layers: list = field(default_factory=list)
    below: float = 1.0
    contact: dict = field(default_factory=dict)
    offset_mm: float = 0.0
    instantaneous: float = 1.0

    def law(self, relative_modulus: float = 1.0):
        """The constitutive law of a material of modulus ``relative_modulus * E_kPa``."""
        from ..mechanics.materials import NeoHooke, NeoHookeStiffening, PronyTerm, Viscoelastic

        E = self.E_kPa * relative_modulus * self.instantaneous
        base = (NeoHookeStiffening(E, self.nu, self.C20_over_E * E) if self.C20_over_E > 0
                else NeoHooke(E, self.nu))
        if self.prony:
            return Viscoelastic(base, tuple(PronyTerm(g, tau) for g, tau in self.prony))
        return base

    def sample(self, merge: bool = True):
        """The material, or the layered sample, of the finite-element model.

        With ``merge`` (default), adjacent materials of equal modulus are one material; without,
        every layer keeps its interface (the mesh then does not change when a ratio passes 1).
        """
        from ..mechanics.layers import RIGID, Layer, LayeredSample

        layers = []
        for t, r in self.layers:  # adjacent materials of equal modulus are one layer
            if math.isinf(r):  # below a rigid base: nothing
                break
            if merge and layers and layers[-1][1] == r:
                layers[-1] = (layers[-1][0] + t, r)
            else:
                layers.append((t, r))
        if merge and layers and layers[-1][1] == self.below:  # the last layer is the half-space itself
            layers.pop()
        if not layers:
            return self.law(1.0)
        below = RIGID if math.isinf(self.below) else self.law(self.below)
        return LayeredSample(tuple(Layer(t, self.law(r)) for t, r in layers), below)

@dataclass(frozen=True)
class EffectAxis:
    """One effect axis of an :class:`EffectSurface`.

    Attributes
    ----------
    name : str
        The unit parameter fitted: ``thickness_mm``, ``compliance`` (= 1 / ratio,
        E_top / E_below) or ``C20_over_E`` (C20 / E of stiffening).
    nodes : tuple of float
        Node values.
    coordinate : {"linear", "log"}
        Interpolation coordinate of the unit parameter: ``v`` or ``log(v + shift)``.
    shift : float
        Of the log coordinate (lets a node sit at 0, e.g. a rigid base).
    """

    name: str
    nodes: tuple
    coordinate: str = "linear"
    shift: float = 0.0

    def coords(self, values) -> np.ndarray:
        v = np.asarray(values, dtype=float)
        return np.log(v + self.shift) if self.coordinate == "log" else v

    @property
    def node_coords(self) -> np.ndarray:
        return self.coords(self.nodes)

    def value(self, coordinate: float) -> float:
        """The parameter value at an interpolation coordinate (the inverse of :meth:`coords`)."""
        return float(np.exp(coordinate) - self.shift) if self.coordinate == "log" else float(coordinate)


def stack_parameters(effects, bounds_of, names: list, lo: list, hi: list) -> list:
    """Append the fit parameters of ``effects`` (in order) to ``names``, their ranges to ``lo``, ``hi``.

    Parameters
    ----------
    effects : sequence of Effect
    bounds_of : callable
        ``bounds_of(effect) -> {fit name: (lower, upper)}`` in the parameters' units.
    names, lo, hi : list
        Extended in place.

    Returns
    -------
    list of (Effect, slice)
        Where each effect's fit parameters sit in ``names``.
    """
    out = []
    for e in effects:
        bounds = bounds_of(e)
        start = len(names)
        for k in e.fit_names:
            names.append(k)
            lo.append(bounds[k][0])
            hi.append(bounds[k][1])
        out.append((e, slice(start, len(names))))
    return out


@dataclass
class Evaluation:
    """A fitted force model being evaluated on one measured history (see :meth:`Effect.apply`).

    Attributes
    ----------
    depth_mm : ndarray
        Recorded depths (mm).
    time_s : ndarray or None
        Times (s).
    h_mm : ndarray
        Depth below the contact point (mm); :data:`DEPTH` effects change it.
    force_mN : ndarray or None
        The force (mN): the elastic force after the :data:`ELASTIC` stage, then changed
        by :data:`HISTORY` and :data:`FORCE` effects.
    radius_mm : float
    kind : ndarray of str or None
        The segment of each point (``approach``, ``hold``, ``retract``; instrument effects act per segment).
    baseline : Baseline or None
        The line the preparation subtracted from the recorded force
        (:class:`~skin_indent.measurement.contact.Baseline`; the instrument's effects remove from
        themselves what it holds of them).
    deflection_mm : ndarray or None
        The probe's cantilever deflection, the recorded baseline-free force over its spring constant (mm):
        the base (piezo) and the probe's body sit at ``depth_mm + deflection_mm``
        (:attr:`~skin_indent.measurement.PreparedCurve.deflection_mm`); None where no cantilever shows.
    cache : dict
        Per-model storage for expensive intermediate results (e.g. relaxation weights).
    """

    depth_mm: np.ndarray
    time_s: np.ndarray | None
    h_mm: np.ndarray
    radius_mm: float
    force_mN: np.ndarray | None = None
    cache: dict = field(default_factory=dict)
    kind: np.ndarray | None = None
    baseline: object = None
    deflection_mm: np.ndarray | None = None


class Effect:
    """Base class of the physical effects (see the module docstring).

    Subclasses set the class attributes and override the methods of their stage.

    Attributes
    ----------
    name : str
        The name used everywhere (API, CLI, JSON, reports).
    description : str
    parameters : tuple of EffectParameter
        As users read them (model parameters).
    stage : str
        :data:`ELASTIC`, :data:`DEPTH`, :data:`HISTORY`, :data:`FORCE` or :data:`WEIGHED`.
    needs_history : bool
        The forward model needs a time history (a protocol).
    fit_names : tuple of str
        The coordinates it is fitted in (default: its parameter names).
    linear_in_E : bool
        The fitted force stays exactly proportional to E (lets the fit take dF/dE exactly).
    repeatable : bool
        May appear more than once in a model (e.g. two layers).
    per_curve : bool
        Its parameters belong to each measurement, not to the sample: when several curves of
        one sample are fitted together (:class:`~skin_indent.models.JointModel`), every curve has
        its own (the contact point of each curve, ``offset_mm[2]``), while the material's
        parameters are shared.
    kind : str
        Effects of one kind are alternative descriptions of one mechanism (``relaxation``: the
        kernels ``viscoelastic`` and ``viscoelastic_powerlaw``): a model has at most one of a kind, and the
        diagnosis ranks them against each other instead of stacking them. "": none.
    instrument : bool
        An effect of the measurement (drag on the probe, a baseline's drift), not of the sample: the
        diagnosis fits it with the sample's parameters but names it apart (``instrument``), and a curve
        that the instrument's effects alone explain is ``none`` for the sample.
    """

    name: str = ""
    description: str = ""
    parameters: tuple = ()
    stage: str = FORCE
    needs_history: bool = False
    linear_in_E: bool = True
    repeatable: bool = False
    per_curve: bool = False
    kind: str = ""
    instrument: bool = False

    def __repr__(self) -> str:
        return f"<effect {self.name}: {self.description}>"

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def fit_names(self) -> tuple[str, ...]:
        return self.parameter_names

    def off_values(self) -> dict[str, float]:
        return {p.name: p.off for p in self.parameters if p.off is not None}

    # ------------------------------------------------------------- forward model
    def configure(self, spec: ForwardSpec, values: dict) -> None:
        """Put the effect with model parameters ``values`` into the finite-element ``spec``."""
        raise NotImplementedError(f"the {self.name} effect has no finite-element form")

    # ------------------------------------------------------------ fitted model
    def to_fit(self, values: dict, E_kPa: float) -> dict:
        """Fit coordinates of model parameters ``values`` (identity by default)."""
        return {k: float(values[k]) for k in self.fit_names}

    def from_fit(self, fit: dict, E_kPa: float) -> dict:
        """Model parameters of fit coordinates ``fit`` (identity by default)."""
        return {k: float(fit[k]) for k in self.parameter_names}

    def relative(self, values: dict, E_kPa: float) -> dict:
        """The parameters of the unit-modulus curve (E = 1 kPa): moduli and energies relative to E.

        Default: the fit coordinates (:meth:`to_fit`).
        """
        return self.to_fit(values, E_kPa)

    def fit_bounds(self, data, reach_mm: float = math.inf) -> dict:
        """``{fit name: (lower, upper)}`` for a prepared curve ``data`` (default: the admissible range).

        ``reach_mm`` is the deepest indentation the elastic model covers (mm).
        """
        return {p.name: (p.lower, p.upper) for p in self.parameters}

    def insert(self, fitted: list, position: int, new: dict) -> list | None:
        """Fit values of every occurrence of a repeatable effect, top first, when one more
        (``new``, fit names without numbers) is added at ``position`` (0: first) among the
        occurrences ``fitted`` before: the start of a fit of one more occurrence (a second
        layer above, between or below the fitted ones). None: no such start.
        """
        return [*fitted[:position], dict(new), *fitted[position:]]

    def starts(self, data, bounds: dict) -> dict:
        """``{fit name: tuple of start values}``; a fit starts from every combination."""
        out = {}
        for p in self.parameters:
            lo, hi = bounds[p.name]
            if p.off is not None and lo <= p.off <= hi:
                out[p.name] = (p.off,)
            elif math.isfinite(lo) and math.isfinite(hi):
                out[p.name] = (math.sqrt(lo * hi) if p.log and lo > 0 else 0.5 * (lo + hi),)
            else:
                out[p.name] = (p.neutral if p.neutral is not None else 0.0,)
        return out

    def surface_axes(self, max_depth_mm: float) -> tuple:
        """Axes (:class:`~skin_indent.models.effect_surface.EffectAxis`) of an :data:`ELASTIC` effect."""
        raise NotImplementedError(f"{self.name} is not an axis of a response surface")

    def fe_bounds(self, max_depth_mm: float) -> dict:
        """``{fit name: (lower, upper)}`` of an :data:`ELASTIC` effect fitted with the
        finite-element model in the loop (default: the range of its surface axes)."""
        return {a.name: (float(min(a.nodes)), float(max(a.nodes))) for a in self.surface_axes(max_depth_mm)}

    def unit_values(self, axis_values: dict) -> dict:
        """Model parameters at E = 1 kPa of the surface-axis values (an :data:`ELASTIC` effect)."""
        return self.from_fit(axis_values, 1.0)

    def apply(self, ev: Evaluation, fit: dict) -> None:
        """Act on the evaluation ``ev`` with fit coordinates ``fit`` (:data:`DEPTH`, :data:`HISTORY`, :data:`FORCE`)."""
        raise NotImplementedError(f"the {self.name} effect cannot act on a fitted curve")

    # ---------------------------------------------------------------- evidence
    def visible(self, data, noise_mN: float) -> str | None:
        """None if the effect can show in the prepared curve ``data``, else why not."""
        return None

    def visible_in(self, curves, noises_mN) -> str | None:
        """None if the effect can show in the curves of one sample fitted together, else why not.

        Default: it shows in one of them (:meth:`visible`); an effect that only shows when
        curves are compared (relaxation, at two loading speeds) says so by overriding this.

        Parameters
        ----------
        curves : sequence of PreparedCurve
        noises_mN : sequence of float
            Each curve's noise level (mN).
        """
        whys = [self.visible(c, s) for c, s in zip(curves, noises_mN)]
        return None if any(w is None for w in whys) else whys[0]

    def weigh(self, diagnosis, best) -> str:
        """For a :data:`WEIGHED` effect: what it could change in the curve, in words."""
        raise NotImplementedError
