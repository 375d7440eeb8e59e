"""A model: the neo-Hookean half-space plus a set of effects, for finite-element runs."""

from __future__ import annotations

from dataclasses import dataclass

from .base import WEIGHED, BASE_PARAMETERS, EffectParameter, ForwardSpec
from .registry import effect as _effect
from .repeat import check_kinds, instances

#: the base law every model starts from
BASE_MODEL = "neo-hooke"


def model_name(effects) -> str:
    """The name of the model of ``effects`` (names or :class:`~.base.Effect`), as every output spells it:
    ``("layer", "layer")`` -> ``"neo-hooke+layer+layer"``."""
    return BASE_MODEL + "".join(f"+{getattr(e, 'name', e)}" for e in effects)


def parse_effects(model) -> tuple[str, ...]:
    """The effects of a model name: ``"neo-hooke+layer+layer"`` -> ``("layer", "layer")``.

    A sequence of effect names (or a :class:`Model`) is taken as it is. One-line ``ValueError`` for
    a model that does not start with the base law, an unknown effect, an effect given twice that
    cannot repeat, or one that is weighed rather than fitted (friction).

    Examples
    --------
    >>> parse_effects("neo-hooke+layer+layer")
    ('layer', 'layer')
    """
    if isinstance(model, Model):
        parts = list(model.effects)
    elif isinstance(model, str):
        parts = [p.strip() for p in model.split("+")]
        if parts[0] != BASE_MODEL:
            raise ValueError(f"a model starts with {BASE_MODEL} (the base law), e.g. {BASE_MODEL}+layer; "
                             f"got {model!r}")
        parts = parts[1:]
    else:
        parts = list(model)
    names = tuple(_effect(p).name for p in parts)
    instances(names)  # an effect given twice that cannot repeat: one line
    weighed = [n for n in names if _effect(n).stage == WEIGHED]
    if weighed:
        raise ValueError(f"{', '.join(weighed)} is weighed, not fitted: no fitted model has it yet")
    return names


@dataclass(frozen=True)
class Model:
    """The neo-Hookean half-space plus a set of effects.

    Parameters
    ----------
    effects : tuple of str or Effect
        Effects of the vocabulary (:data:`~skin_indent.effects.EFFECTS`), each at most once
        except repeatable ones: ``("layer", "layer")`` is two bonded layers over a
        half-space (the second layer's parameters are ``thickness2_mm``, ``ratio2``).
    radius_mm : float
        Sphere radius, mm.

    Examples
    --------
    >>> m = Model(("layer",))
    >>> m.parameter_names
    ('E_kPa', 'nu', 'thickness_mm', 'ratio')
    >>> (Model.parse("neo-hooke+layer") + "viscoelastic").name
    'neo-hooke+layer+viscoelastic'
    """

    effects: tuple = ()
    radius_mm: float = 6.22

    def __post_init__(self):
        from ..mechanics.contact_law import SphericalIndenter

        names = tuple(e.name for e in instances(self.effects))
        check_kinds(names)  # one relaxation law (viscoelastic or viscoelastic_powerlaw)
        object.__setattr__(self, "effects", names)
        SphericalIndenter(self.radius_mm)

    @classmethod
    def parse(cls, model, radius_mm: float = 6.22) -> "Model":
        """The fitted model of a name (``"neo-hooke+layer+layer"``), a sequence of effect names or a
        :class:`Model` (:func:`parse_effects`: what a fit takes), for a sphere of ``radius_mm`` (mm)."""
        return cls(parse_effects(model), radius_mm)

    def __add__(self, other) -> "Model":
        """This model with more effects: ``model + "layer"``, ``model + ("layer", "adhesion")`` or
        ``model + other_model`` (its effects), as lmfit's ``+`` composes models."""
        more = other.effects if isinstance(other, Model) else (other,) if isinstance(other, str) else tuple(other)
        return Model(self.effects + tuple(_effect(e).name for e in more), self.radius_mm)

    def __str__(self) -> str:
        return self.name

    @property
    def effect_objects(self) -> tuple:
        return instances(self.effects)

    @property
    def name(self) -> str:
        return model_name(self.effects)

    @property
    def parameters(self) -> tuple[EffectParameter, ...]:
        return BASE_PARAMETERS + tuple(p for e in self.effect_objects for p in e.parameters)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def needs_history(self) -> bool:
        return any(e.needs_history for e in self.effect_objects)

    def check(self, theta: dict) -> dict:
        """Complete ``theta`` with off values and check every parameter against its range."""
        out = {}
        for p in self.parameters:
            if p.name in theta:
                value = p.check(theta[p.name])
            elif p.off is not None:
                value = p.off
            elif p.neutral is not None:
                value = p.neutral  # does not matter while its effect is off
            else:
                raise ValueError(f"model {self.name} needs a value for {p.name}")
            out[p.name] = value
        unknown = set(theta) - set(out)
        if unknown:
            raise ValueError(f"model {self.name} has no parameter(s) {sorted(unknown)}")
        return out

    def spec(self, theta: dict) -> ForwardSpec:
        """The :class:`ForwardSpec` of the parameters ``theta``: every effect configures its part."""
        t = self.check(theta)
        spec = ForwardSpec(t["E_kPa"], t["nu"])
        for e in self.effect_objects:
            e.configure(spec, {k: t[k] for k in e.parameter_names})
        return spec

    def sample(self, theta: dict):
        """The material or layered sample of the parameters ``theta`` (mm, kPa, s)."""
        return self.spec(theta).sample()

    def contact(self, theta: dict):
        """The :class:`~skin_indent.mechanics.contact_law.ContactLaw` of ``theta`` (frictionless, non-adhesive by
        default)."""
        from ..mechanics.contact_law import ContactLaw

        return ContactLaw(**self.spec(theta).contact)

    def simulate(self, theta: dict, depth_mm=None, *, protocol=None, mesh="medium", **kwargs):
        """Force-depth curve of the parameters ``theta`` (see :func:`skin_indent.simulate.simulate`).

        History-dependent parameters (viscoelastic, friction) need ``protocol``; the
        offset is applied to the recorded depths.
        """
        from ..mechanics.contact_law import ContactLaw, SphericalIndenter
        from ..simulate import simulate

        spec = self.spec(theta)
        sample = spec.sample()
        contact = ContactLaw(**spec.contact)
        if protocol is None and not (sample.path_independent and contact.path_independent):
            raise ValueError(f"model {self.name} with these parameters needs a protocol (time and depth)")
        return simulate(sample, SphericalIndenter(self.radius_mm), depth_mm if protocol is None else 0.6,
                        protocol=protocol, offset_mm=spec.offset_mm, mesh=mesh,
                        contact=kwargs.pop("contact", contact), **kwargs)

    def unit_parameters(self, theta: dict) -> dict:
        """The parameters of the unit-modulus curve: every effect's parameters relative to E (C20 / E, w / E...)."""
        t = self.check(theta)
        out = {"nu": t["nu"]}
        for e in self.effect_objects:
            out.update(e.relative({k: t[k] for k in e.parameter_names}, t["E_kPa"]))
        return out
