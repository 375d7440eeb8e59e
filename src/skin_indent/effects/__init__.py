"""Physical effects: what a homogeneous neo-Hookean half-space misses, one module each.

The base model is a neo-Hookean half-space (E, nu). Each effect adds what the simple
model misses, with parameters that response surfaces, fits and diagnosis take like E
and nu. The vocabulary (:data:`EFFECTS`, in this order):

``layer`` (:mod:`.layer`)
    a bonded top layer over a half-space of another modulus, or over a rigid base
    (``ratio = inf``): ``thickness_mm``, ``ratio`` = E_below / E_top.
``stiffening`` (:mod:`.stiffening`)
    strain stiffening, W = W_NH + C20 (I1b - 3)^2: ``C20_kPa``.
``viscoelastic`` (:mod:`.viscoelastic`)
    quasi-linear viscoelasticity with one Prony term: ``g1``, ``tau1_s``.
``friction`` (:mod:`.friction`)
    Coulomb friction between sphere and skin (stick and slip): ``mu``.
``adhesion`` (:mod:`.adhesion`)
    work of adhesion ``w_mJ_per_m2`` (pull-off on unloading).
``viscoelastic_powerlaw`` (:mod:`.powerlaw`)
    power-law relaxation E(t) = E (t / 1 s)^-beta of cells and tissues: ``beta`` (the other
    relaxation kernel: a model has ``viscoelastic`` or ``viscoelastic_powerlaw``).
``offset`` (:mod:`.offset`)
    a shift of the contact point: ``offset_mm`` (a nuisance parameter of fits).

Effects of the instrument, not of the sample (:attr:`Effect.instrument`), fitted with the
sample's parameters and named apart:

``drag`` (:mod:`.drag`)
    hydrodynamic drag on the probe: ``eta_mPa_s`` (lubrication near the surface),
    ``drag_N_s_per_m`` (the cantilever's far field).
``baselines``, ``hold_baseline`` (:mod:`.segment_baseline`)
    the baseline's drift during the retract and the hold, continuous in time:
    ``retract_drift_mN_per_s``, ``hold_drift_mN_per_s``.

Every effect has an *off* value that gives back the base model exactly. In a
:class:`Model`, ``E_kPa`` is the modulus of the top material and every other modulus
is relative to it, so the force is exactly proportional to ``E_kPa``.

What an effect is made of, and how to add one: :mod:`.base` (:class:`Effect`) and
:func:`register`.
"""

from .adhesion import RANGE_MM as ADHESION_RANGE_MM
from .adhesion import Adhesion
from .base import BASE_PARAMETERS, DEPTH, ELASTIC, FORCE, HISTORY, STAGE_ORDER, WEIGHED, Effect, EffectAxis, EffectParameter, \
    Evaluation, ForwardSpec
from .drag import Drag
from .friction import Friction
from .layer import Layer
from .model import BASE_MODEL, Model, model_name, parse_effects
from .offset import Offset
from .powerlaw import PowerLaw
from .registry import EFFECTS, effect, register, unregister
from .repeat import Repeat, instances, numbered
from .segment_baseline import SegmentBaseline
from .stiffening import Stiffening
from .viscoelastic import Viscoelastic

#: the contact point as a fit parameter: every fit of a curve recorded from before contact has it
CONTACT_POINT = Offset()

for _e in (Layer(), Stiffening(), Viscoelastic(), Friction(), Adhesion(), CONTACT_POINT, PowerLaw(), Drag(),
           SegmentBaseline("retract", "baselines"), SegmentBaseline("hold", "hold_baseline")):
    register(_e, replace=True)
del _e

#: the effects of the instrument (drag, baselines), in registration order
INSTRUMENT = tuple(n for n, e in EFFECTS.items() if e.instrument)

__all__ = ["ADHESION_RANGE_MM", "INSTRUMENT", "Drag", "SegmentBaseline", "BASE_PARAMETERS", "CONTACT_POINT", "DEPTH", "STAGE_ORDER", "EFFECTS", "ELASTIC", "FORCE", "HISTORY", "WEIGHED",
           "Adhesion", "Effect", "EffectAxis", "EffectParameter", "Evaluation", "ForwardSpec", "Friction", "Layer", "Model", "Offset", "BASE_MODEL", "model_name", "parse_effects",
           "Repeat", "Stiffening", "Viscoelastic", "effect", "instances", "numbered", "register", "unregister"]
