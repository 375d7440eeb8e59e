"""The scale of a curve (an AFM or cell-scale sphere, or a skin-scale one) and the units its results are read in.

One rule, :func:`afm_scale`, decides; everything that depends on the scale asks it:

- the text of a fit, the lines of a batch, the plots of a fit and the text, sentences, HTML
  page and figures of a diagnosis show lengths, forces and moduli in the units of the scale
  (:func:`display_units`: um, nN and Pa for AFM-scale curves, mm, mN and kPa for skin);
- the default of Poisson's ratio of :func:`skin_indent.fitting.fit`: held at 0.5 (the
  incompressible limit, the AFM field's convention) at AFM scale, fitted at skin scale as
  in Delalleau et al. (2006).

JSON, TSV and CSV outputs keep the package units whatever the scale (mm, mN, kPa, in the
names: ``E_kPa``, ``contact_point_mm``, ``noise_mN``), so tables of mixed folders stay one
table and read back the same way.

Notes and flags that hold numbers (the incompressible limit's extrapolation, a value held, a
prior, a parameter its curve does not determine, where a model departs from a curve, the
measurement that would separate two explanations) are :class:`UnitText`: a ``str`` in package
units (what JSON keeps) that :func:`shown_in` writes in the units of the scale (what the text
of a fit or a diagnosis prints), from the same numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["AFM_RADIUS_MM", "AFM_UNITS", "PACKAGE_UNITS", "SKIN_UNITS", "DisplayUnits", "Name", "Quantity", "Unit",
           "UnitText", "afm_scale", "display_units", "format_modulus", "joined", "shown_in"]

#: spheres smaller than this radius (mm) are AFM or cell-scale probes: colloidal AFM probes and
#: nanoindenter tips are 1-250 um in radius (Chiaro 3-250 um), skin and tissue indenters use
#: spheres of 1 mm and more (6.22 mm in Delalleau et al. 2006)
AFM_RADIUS_MM = 0.5


def afm_scale(radius_mm: float) -> bool:
    """True for a sphere of AFM or cell scale, radius below :data:`AFM_RADIUS_MM` (0.5 mm).

    The radius alone decides: it is known before any fit (given, from the file, or the
    skin default), and a force in the wrong unit does not move a curve from one field's
    conventions to the other's (the scale checks of the fit say so instead).

    Parameters
    ----------
    radius_mm : float
        Sphere radius (mm).
    """
    return bool(math.isfinite(radius_mm) and 0 < radius_mm < AFM_RADIUS_MM)


@dataclass(frozen=True)
class DisplayUnits:
    """The units results of one scale are shown in, and the factors from the package units.

    Attributes
    ----------
    length, force, modulus : str
        Unit names (``"um"``, ``"nN"``, ``"Pa"``; or ``"mm"``, ``"mN"``, ``"kPa"``).
    per_mm, per_mN, per_kPa : float
        Factors from mm, mN and kPa to those units.
    """

    length: str
    force: str
    modulus: str
    per_mm: float
    per_mN: float
    per_kPa: float

    @property
    def is_package(self) -> bool:
        """True when these are the package units (mm, mN, kPa): nothing to convert."""
        return self.per_mm == self.per_mN == self.per_kPa == 1.0

    def name(self, name: str) -> str:
        """A parameter's name with its unit suffix in these units: ``E_kPa`` -> ``E_Pa``,
        ``offset_mm`` -> ``offset_um``, ``offset_mm[2]`` (curve 2's) -> ``offset_um[2]``; a name
        without a unit suffix as it is."""
        name, curve = _curve_suffix(name)
        for suffix, unit in (("_kPa", self.modulus), ("_mm", self.length), ("_mN", self.force)):
            if name.endswith(suffix):
                return name[: -len(suffix)] + "_" + unit + curve
        return name + curve

    def factor(self, name: str) -> float:
        """The factor from a parameter's package unit (by its suffix) to these units."""
        name, _ = _curve_suffix(name)
        for suffix, k in (("_kPa", self.per_kPa), ("_mm", self.per_mm), ("_mN", self.per_mN)):
            if name.endswith(suffix):
                return k
        return 1.0


def _curve_suffix(name: str) -> tuple[str, str]:
    """``"offset_mm[2]"`` -> ``("offset_mm", "[2]")`` (a curve's own parameter of a joint fit)."""
    if name.endswith("]") and "[" in name:
        base, _, k = name.rpartition("[")
        return base, "[" + k
    return name, ""


SKIN_UNITS = DisplayUnits("mm", "mN", "kPa", 1.0, 1.0, 1.0)
AFM_UNITS = DisplayUnits("um", "nN", "Pa", 1e3, 1e6, 1e3)
#: the package units (mm, mN, kPa), those of every JSON, TSV and CSV output: :data:`SKIN_UNITS`
PACKAGE_UNITS = SKIN_UNITS


def display_units(radius_mm: float) -> DisplayUnits:
    """:data:`AFM_UNITS` (um, nN, Pa) for an AFM-scale sphere (:func:`afm_scale`), else the
    package units :data:`SKIN_UNITS` (mm, mN, kPa).

    Parameters
    ----------
    radius_mm : float
        Sphere radius (mm).
    """
    return AFM_UNITS if afm_scale(radius_mm) else SKIN_UNITS


def format_modulus(E_kPa: float) -> str:
    """A modulus in the unit that suits its size: ``0.0046`` -> ``"4.6 Pa"``, ``2e5`` -> ``"200 MPa"``."""
    for unit, k, floor in (("MPa", 1e-3, 1e3), ("kPa", 1.0, 1.0), ("Pa", 1e3, 0.0)):
        if abs(E_kPa) >= floor:
            return f"{E_kPa * k:.3g} {unit}"
    return f"{E_kPa * 1e3:.3g} Pa"


#: the package units a :class:`Quantity` may carry, and the :class:`DisplayUnits` attributes of each
_KINDS = {"kPa": ("modulus", "per_kPa"), "mm": ("length", "per_mm"), "mN": ("force", "per_mN")}


@dataclass(frozen=True)
class Quantity:
    """A number in a package unit, for a :class:`UnitText`.

    Formatted (``f"{q:.5g}"``) it is the number and its unit (``"0.17587 kPa"``); in a
    :class:`UnitText` written in other units it is converted first (``"175.87 Pa"``).

    Parameters
    ----------
    value : float
        In the package unit ``unit``.
    unit : {"kPa", "mm", "mN"} or str
        The package unit; or a parameter name with a unit suffix (``"offset_mm"``,
        ``"E_kPa"``, ``"nu"``), for a value written after the parameter's name: converted by the
        name's suffix, written without a unit (the name says it).
    """

    value: float
    unit: str

    def shown(self, units: DisplayUnits) -> "_Shown":
        """This quantity in ``units``: a value that formats with its unit name (or none, for a parameter)."""
        if self.unit in _KINDS:
            kind, per = _KINDS[self.unit]
            return _Shown(self.value * getattr(units, per), getattr(units, kind))
        return _Shown(self.value * units.factor(self.unit), "")

    def __format__(self, spec: str) -> str:
        return format(self.shown(SKIN_UNITS), spec)


@dataclass(frozen=True)
class _Shown:
    value: float
    unit: str

    def __format__(self, spec: str) -> str:
        return f"{self.value:{spec}}" + (f" {self.unit}" if self.unit else "")


@dataclass(frozen=True)
class Unit:
    """A unit's name in a :class:`UnitText`, after numbers written without one (``"from {a:.3g} to
    {b:.3g} {unit}"``): the package unit (``"mm"``, ``"mN"`` or ``"kPa"``) written as the units shown
    name it (``"um"``, ``"nN"``, ``"Pa"`` in :data:`AFM_UNITS`).

    Parameters
    ----------
    unit : {"kPa", "mm", "mN"}
        The package unit.
    """

    unit: str

    def __post_init__(self):
        if self.unit not in _KINDS:
            raise ValueError(f"Unit takes one of {', '.join(_KINDS)}, got {self.unit!r}")

    def shown(self, units: DisplayUnits) -> str:
        return getattr(units, _KINDS[self.unit][0])

    def __format__(self, spec: str) -> str:
        return format(self.unit, spec)


@dataclass(frozen=True)
class Name:
    """A parameter's name in a :class:`UnitText`: written with the unit suffix of the units shown
    (``E_kPa`` -> ``E_Pa`` in AFM units, :meth:`DisplayUnits.name`)."""

    name: str

    def shown(self, units: DisplayUnits) -> str:
        return units.name(self.name)

    def __format__(self, spec: str) -> str:
        return format(self.name, spec)


class UnitText(str):
    """A message with numbers in units: a ``str`` in package units that reads in any units.

    ``UnitText("E = {E:.5g}", E=Quantity(0.13668, "kPa"))`` is the string
    ``"E = 0.13668 kPa"`` (what JSON keeps; every ``str`` operation sees it), and
    :meth:`in_units` (or :func:`shown_in`) writes it in other units from the same numbers
    (``"E = 136.68 Pa"`` in :data:`AFM_UNITS`).

    Parameters
    ----------
    template : str
        A :meth:`str.format` template.
    **fields
        Its fields: :class:`Quantity`, :class:`Name` (a parameter's name), :class:`Unit` (a unit's
        name), another :class:`UnitText` (written in the same units) or any other value (written
        as it is).
    """

    def __new__(cls, template: str, **fields):
        text = super().__new__(cls, template.format(**fields))
        text.template, text.fields = template, dict(fields)
        return text

    def in_units(self, units: DisplayUnits) -> str:
        """The text in ``units`` (a plain ``str``)."""
        return self.template.format(**{k: _field_in(v, units) for k, v in self.fields.items()})

    def __reduce__(self):  # pickled (to worker processes) with its template and fields
        return _unit_text, (self.template, self.fields)


def _unit_text(template: str, fields: dict) -> UnitText:
    return UnitText(template, **fields)


def _field_in(field, units: DisplayUnits):
    """A field of a :class:`UnitText` as written in ``units``."""
    if isinstance(field, UnitText):
        return field.in_units(units)
    if isinstance(field, (Quantity, Name, Unit)):
        return field.shown(units)
    return field


def joined(separator: str, parts) -> str:
    """``separator.join(parts)``, a :class:`UnitText` when a part is one (each part a field of it, so
    that the whole reads in any units), else a plain ``str``.

    Parameters
    ----------
    separator : str
    parts : iterable of str
        Plain texts and :class:`UnitText`.
    """
    parts = list(parts)
    if not any(isinstance(p, UnitText) for p in parts):
        return separator.join(parts)
    sep = separator.replace("{", "{{").replace("}", "}}")
    return UnitText(sep.join(f"{{p{i}}}" for i in range(len(parts))), **{f"p{i}": p for i, p in enumerate(parts)})


def shown_in(text, units: DisplayUnits) -> str:
    """A note or flag as the text of a fit prints it: a :class:`UnitText` in ``units``, any other
    text as it is."""
    return text.in_units(units) if isinstance(text, UnitText) else str(text)
