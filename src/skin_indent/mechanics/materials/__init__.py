"""Constitutive laws: one law per module, all following :class:`Material`."""

from .base import Material, ParameterInfo, lame_parameters
from .linear_elastic import LinearElastic
from .neo_hooke import NeoHooke
from .stiffening import NeoHookeStiffening
from .viscoelastic import PronyTerm, Viscoelastic

__all__ = ["Material", "ParameterInfo", "lame_parameters", "LinearElastic", "NeoHooke", "NeoHookeStiffening",
           "PronyTerm", "Viscoelastic"]
