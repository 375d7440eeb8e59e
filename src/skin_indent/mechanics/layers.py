"""Layered samples: bonded layers over a half-space or over a rigid base.

Skin is layered (epidermis ~0.1 mm, dermis ~1-1.5 mm on the forearm, hypodermis a
few mm, then muscle). A :class:`LayeredSample` stacks :class:`Layer` objects, top
first, over a ``substrate``: a material (a half-space below the last layer) or
:data:`RIGID` (the layers are bonded to a rigid base). The finite-element model
assigns the material at each quadrature point from its depth; the mesh is refined
along the interfaces under the contact and its vertices are moved onto them there
(:func:`skin_indent.mechanics.mesh.conform_to_interfaces`), so near the contact every
triangle lies in one material, and far from it, where triangles are larger than the
layers, an interface may still cut through them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .materials import Material

#: Substrate value for layers bonded to a rigid base.
RIGID = "rigid"


@dataclass(frozen=True)
class Layer:
    """One bonded layer.

    Parameters
    ----------
    thickness_mm : float
        Thickness, mm (> 0).
    material : Material
        Its constitutive law.
    """

    thickness_mm: float
    material: Material

    def __post_init__(self):
        t = self.thickness_mm
        if not (isinstance(t, (int, float, np.floating)) and math.isfinite(t) and t > 0):
            raise ValueError(f"layer thickness must be a finite number > 0 mm, got {t!r}")
        if not isinstance(self.material, Material):
            raise ValueError(f"a layer needs a Material, got {type(self.material).__name__}")


@dataclass(frozen=True)
class LayeredSample:
    """Bonded layers (top first) over a half-space ``substrate`` or a rigid base.

    Parameters
    ----------
    layers : sequence of Layer
        At least one layer, top first.
    substrate : Material or "rigid"
        The half-space below the layers, or :data:`RIGID`.
    """

    layers: tuple
    substrate: Material | str

    def __post_init__(self):
        layers = tuple(self.layers)
        if not layers or not all(isinstance(layer, Layer) for layer in layers):
            raise ValueError("a layered sample needs at least one Layer(thickness_mm, material)")
        if not (self.substrate == RIGID or isinstance(self.substrate, Material)):
            raise ValueError(f"the substrate must be a Material or {RIGID!r}, got {self.substrate!r}")
        laws = self.materials
        if len({m.small_strain for m in laws}) > 1:
            raise ValueError("all materials of a sample must be either small-strain or finite-strain")
        object.__setattr__(self, "layers", layers)

    @property
    def rigid_base(self) -> bool:
        return isinstance(self.substrate, str)

    @property
    def materials(self) -> list:
        """The laws from the top down (substrate last unless rigid)."""
        return [layer.material for layer in self.layers] + ([] if self.rigid_base else [self.substrate])

    @property
    def interfaces_mm(self) -> np.ndarray:
        """Depths of the interfaces below the surface, mm (the last one is the base when rigid)."""
        return np.cumsum([layer.thickness_mm for layer in self.layers])

    @property
    def total_thickness_mm(self) -> float:
        return float(self.interfaces_mm[-1])

    @property
    def path_independent(self) -> bool:
        return all(m.path_independent for m in self.materials)

    @property
    def small_strain(self) -> bool:
        return self.materials[0].small_strain

    @property
    def reference_modulus(self) -> float:
        """The stiffest reference modulus (scales the contact penalty)."""
        return max(m.reference_modulus for m in self.materials)

    @property
    def name(self) -> str:
        base = "rigid base" if self.rigid_base else f"{self.substrate.name} half-space"
        return f"{len(self.layers)} layer(s) over a {base}"

    def parameters(self) -> dict[str, float]:
        out = {}
        for k, layer in enumerate(self.layers, 1):
            out[f"thickness{k}_mm"] = float(layer.thickness_mm)
            out.update({f"{name}_layer{k}": v for name, v in layer.material.parameters().items()})
        if not self.rigid_base:
            out.update({f"{name}_substrate": v for name, v in self.substrate.parameters().items()})
        return out

    def regions(self, z_mm: np.ndarray) -> list:
        """``(mask, material)`` per layer (and substrate) for quadrature points at heights ``z_mm`` (<= 0)."""
        depth = -np.asarray(z_mm)
        edges = np.r_[-np.inf, self.interfaces_mm, np.inf]
        out = []
        for k, law in enumerate(self.materials):
            mask = (depth > edges[k]) & (depth <= edges[k + 1])
            if k == 0:
                mask |= depth <= 0
            if np.any(mask):
                out.append((mask, law))
        return out
