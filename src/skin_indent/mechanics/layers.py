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

Layers on a rigid base are squeezed between the sphere and the base: their contact
stiffness grows like the confined (P-wave) modulus over the remaining thickness, far
beyond a half-space's. The contact penalty follows it
(:class:`ConfinedPenalty`, built on
:attr:`LayeredSample.confined_modulus_kPa`), and a curve pressed deeper than
:data:`SQUEEZE_FROM` of the thickness is solved at extra depths
(:meth:`LayeredSample.squeeze_depths_mm`), where the force steepens.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .materials import Material

#: Substrate value for layers bonded to a rigid base.
RIGID = "rigid"
#: Layers on a rigid base pressed deeper than this fraction of their thickness T get extra
#: solved depths, uniform in log(T - h) with steps of :data:`SQUEEZE_STEP`
#: (:meth:`LayeredSample.squeeze_depths_mm`). The force then grows like a power of 1/(T - h):
#: measured (R = 1 mm, T = 0.7 mm pressed to h/T = 0.83, nu = 0.49, coarse and medium meshes),
#: the spline of F / h^1.5 between the 12 geometric depths of a curve was 1.1 % off direct
#: solves at h/T = 0.7-0.8 (20 geometric depths: 0.45 %); with the 6 extra depths, within 1e-4
#: beyond h/T = 0.5, for 10-25 % more Newton iterations.
SQUEEZE_FROM = 0.4
SQUEEZE_STEP = 0.25


def p_wave_modulus(law: Material) -> float:
    """Confined (P-wave) modulus of a law, kPa: ``M = E (1 - nu) / ((1 + nu)(1 - 2 nu))``, the
    stiffness of a layer compressed without lateral strain (``E`` its reference modulus; a law
    without a Poisson's ratio gives ``E``)."""
    nu = getattr(law, "nu", None)
    E = float(law.reference_modulus)
    if nu is None:
        return E
    return E * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu))


def p_wave_modulus_derivative(law: Material, name: str) -> float:
    """dM/dp of :func:`p_wave_modulus` for a parameter of ``law.sensitivity_parameters`` (kPa per unit)."""
    nu = getattr(law, "nu", None)
    dE = float(law.reference_modulus_derivative(name))
    if nu is None:
        return dE
    m = (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu))
    out = dE * m
    if name == "nu":
        out += float(law.reference_modulus) * m * (-1.0 / (1.0 - nu) - 1.0 / (1.0 + nu) + 2.0 / (1.0 - 2.0 * nu))
    return out


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

    @property
    def confined_modulus_kPa(self) -> float:
        """The layers' confined modulus in series through the thickness, kPa:
        ``T / sum(t_i / M_i)`` with ``M_i`` the :func:`p_wave_modulus` of each layer (the stiffness
        per unit area of the stack pressed uniformly onto a rigid base is this over ``T``)."""
        return self.total_thickness_mm / sum(layer.thickness_mm / p_wave_modulus(layer.material)
                                             for layer in self.layers)

    def confined_modulus_derivative(self, k: int, name: str) -> float:
        """d(:attr:`confined_modulus_kPa`)/dp for the parameter ``name`` of material ``k`` (kPa per unit;
        0 for the substrate)."""
        if k >= len(self.layers):
            return 0.0
        layer = self.layers[k]
        M = p_wave_modulus(layer.material)
        Ms = self.confined_modulus_kPa
        return Ms**2 / self.total_thickness_mm * layer.thickness_mm / M**2 * p_wave_modulus_derivative(
            layer.material, name)

    def squeeze_depths_mm(self, max_depth_mm: float) -> np.ndarray:
        """Extra depths to solve (mm) for a curve to ``max_depth_mm`` on a rigid base.

        For ``max_depth_mm`` beyond :data:`SQUEEZE_FROM` of the thickness ``T``: depths ``h``
        with ``log(T - h)`` uniform in steps of at most :data:`SQUEEZE_STEP` from
        ``T - h = (1 - SQUEEZE_FROM) T`` down to ``T - max_depth_mm`` (the last one excluded: the
        deepest depth is solved anyway); none otherwise, or over a half-space.
        """
        T = self.total_thickness_mm
        if not self.rigid_base or not SQUEEZE_FROM * T < max_depth_mm < T:
            return np.empty(0)
        lo, hi = math.log(T - max_depth_mm), math.log((1.0 - SQUEEZE_FROM) * T)
        n = math.ceil((hi - lo) / SQUEEZE_STEP)
        return np.sort(T - np.exp(np.linspace(lo, hi, n + 1)[1:]))

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


#: Layers bonded to a rigid base: the penalty per area follows the contact stiffness of the
#: squeezed layer, ``CONFINED_PENALTY`` M / (T - h) against E / a for a half-space (see
#: :class:`ConfinedPenalty`). Measured (R = 1 mm, layers of 0.05-1 mm, nu = 0.3-0.49): with the
#: half-space's penalty alone the penetration reached 0.4 % of the depth at h/T = 0.5 (force
#: 0.5 % low) and, from h/T = 0.7-0.9, a surface mode on the penalty's soft foundation made the
#: tangent indefinite (Newton failed: 0.71 on the medium mesh, nu = 0.49, T/R = 0.05). 0.1 keeps
#: the penetration near the half-space's (~1e-3 of the depth) and solves to h/T = 0.91-0.98 on
#: the three meshes; 0.3 cost 10-30 % more Newton iterations, 3 did not converge to 1e-5.
CONFINED_PENALTY = 0.1
#: The remaining thickness in :class:`ConfinedPenalty` is taken at least this fraction of T.
CONFINED_FLOOR = 0.05


class ConfinedPenalty:
    r"""Factor of the contact penalty of layers bonded to a rigid base, as a function of the depth.

    The penalty of :class:`IndentationProblem` is scaled for a half-space,
    :math:`\epsilon_0 = \kappa E_{ref} / a_{max}`. A layer of thickness :math:`T` squeezed
    between the sphere and a rigid base is stiffer: per unit area about its confined modulus
    :math:`M` (:attr:`~.layers.LayeredSample.confined_modulus_kPa`, 17 E at nu = 0.49) over
    the remaining thickness :math:`T - h`, against :math:`E/a` for a half-space. At depth
    :math:`h` the penalty is :math:`\epsilon_0` times

    .. math::

        s(h) = \max\Big(1,\ c\, \frac{M \sqrt{R h}}{E_{ref} \max(T - h, f T)}\Big)

    with :math:`c` = :data:`CONFINED_PENALTY` and :math:`f` = :data:`CONFINED_FLOOR`, so
    that the penetration stays a similar fraction of the depth as on a half-space (where
    :math:`s = 1`: thick layers, small depths). It is a function of the depth alone: the
    curve stays path independent and proportional to the moduli.

    Parameters
    ----------
    sample : LayeredSample
        Layers on a rigid base.
    radius_mm : float
        Sphere radius R, mm.
    e_ref : float
        The reference modulus of the half-space penalty, kPa.
    """

    def __init__(self, sample: LayeredSample, radius_mm: float, e_ref: float):
        self.modulus_kPa = sample.confined_modulus_kPa
        self.thickness_mm = sample.total_thickness_mm
        self.radius_mm = float(radius_mm)
        self.e_ref = float(e_ref)

    def raw(self, depth_mm: float) -> float:
        """The factor before it is bounded below by 1."""
        T = self.thickness_mm
        rest = max(T - depth_mm, CONFINED_FLOOR * T)
        a = math.sqrt(self.radius_mm * max(depth_mm, 0.0))
        return CONFINED_PENALTY * self.modulus_kPa * a / (self.e_ref * rest)

    def active(self, depth_mm: float) -> bool:
        """Whether the factor exceeds 1 at ``depth_mm`` (then the penalty follows ``M``, not ``E_ref``)."""
        return self.raw(depth_mm) > 1.0

    def __call__(self, depth_mm: float) -> float:
        return max(1.0, self.raw(depth_mm))
