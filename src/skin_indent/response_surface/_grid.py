"""Grid of a response surface and the CLI range parser."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def parse_range(text: str) -> np.ndarray:
    """Parse a CLI range ``"MIN:MAX:N"`` (linear) or ``"MIN:MAX:N:log"`` (geometric).

    Parameters
    ----------
    text : str
        For example ``"1:100:8"`` (8 values from 1 to 100, ends included).

    Returns
    -------
    numpy.ndarray
        Increasing 1-D array of ``N`` values, in the unit of MIN and MAX.

    Raises
    ------
    ValueError
        On a malformed string, with the reason.

    Examples
    --------
    >>> parse_range("0.2:0.49:3")
    array([0.2  , 0.345, 0.49 ])
    """
    parts = str(text).strip().split(":")
    if len(parts) not in (3, 4):
        raise ValueError(f"range {text!r}: expected 'MIN:MAX:N' or 'MIN:MAX:N:log'")
    try:
        lo, hi = float(parts[0]), float(parts[1])
    except ValueError:
        raise ValueError(f"range {text!r}: MIN and MAX must be numbers") from None
    try:
        n = int(parts[2])
    except ValueError:
        raise ValueError(f"range {text!r}: N must be an integer, got {parts[2]!r}") from None
    spacing = parts[3].strip().lower() if len(parts) == 4 else "lin"
    if spacing not in ("lin", "log"):
        raise ValueError(f"range {text!r}: spacing must be 'lin' or 'log', got {spacing!r}")
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise ValueError(f"range {text!r}: MIN and MAX must be finite")
    if n < 1:
        raise ValueError(f"range {text!r}: N must be >= 1, got {n}")
    if n == 1 and lo != hi:
        raise ValueError(f"range {text!r}: N = 1 needs MIN == MAX")
    if n > 1 and not lo < hi:
        raise ValueError(f"range {text!r}: MIN must be < MAX, got {lo:g} >= {hi:g}")
    if spacing == "log":
        if lo <= 0:
            raise ValueError(f"range {text!r}: log spacing needs MIN > 0")
        return np.geomspace(lo, hi, n)
    return np.linspace(lo, hi, n)


def _axis(name, values, lo, hi, min_size, unit):
    a = np.array(values, dtype=float).ravel()
    if a.size < min_size:
        raise ValueError(f"grid {name}: needs at least {min_size} values, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"grid {name}: values must be finite")
    if np.any(np.diff(a) <= 0):
        raise ValueError(f"grid {name}: values must be strictly increasing")
    if a[0] <= lo or a[-1] >= hi:
        raise ValueError(f"grid {name}: values must lie in ({lo:g}, {hi:g}) {unit}".rstrip())
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class SurfaceGrid:
    """Grid of a response surface.

    Parameters
    ----------
    depth_mm : array_like
        Indentation depths h (mm), strictly increasing, > 0; at least 2.
    E_kPa : array_like
        Young's moduli E (kPa), strictly increasing, > 0; at least 2.
    nu : array_like
        Poisson's ratios (-), strictly increasing, in (-1, 0.5); at least 1.
    """

    depth_mm: np.ndarray
    E_kPa: np.ndarray
    nu: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "depth_mm", _axis("depth_mm", self.depth_mm, 0, np.inf, 2, "mm"))
        object.__setattr__(self, "E_kPa", _axis("E_kPa", self.E_kPa, 0, np.inf, 2, "kPa"))
        object.__setattr__(self, "nu", _axis("nu", self.nu, -1, 0.5, 1, ""))

    @classmethod
    def paper(cls, depth_max_mm: float = 0.6, n_depth: int = 100) -> "SurfaceGrid":
        """The grid size of Delalleau et al. (2006): 100 depths x 8 E x 6 nu.

        The paper does not list its node values. Here: depths equally spaced from
        ``depth_max_mm / n_depth`` to ``depth_max_mm`` (0.006-0.6 mm); E geometric from
        1 to 100 kPa (1, 1.93, 3.73, 7.20, 13.9, 26.8, 51.8, 100), i.e. equal relative
        resolution, which costs nothing since F is exactly linear in E; nu equally
        spaced from 0.2 to 0.49 (step 0.058).

        Parameters
        ----------
        depth_max_mm : float
            Largest depth (mm).
        n_depth : int
            Number of depths.
        """
        return cls(
            depth_mm=np.linspace(depth_max_mm / n_depth, depth_max_mm, n_depth),
            E_kPa=np.geomspace(1.0, 100.0, 8),
            nu=np.linspace(0.2, 0.49, 6),
        )

    @classmethod
    def unit_radius(cls, depth_ratio_max: float = 0.5, n_depth: int = 100, *, E_kPa=None,
                    nu=None) -> "SurfaceGrid":
        """A grid for a sphere of radius 1 mm, reused for any radius by similarity.

        For a neo-Hookean half-space F(h; E, R, nu) = E R^2 phi(h/R, nu) exactly (no
        length scale in the law, and the mesh is scaled by sqrt(R h_max)), so a surface
        built at R = 1 mm serves every radius (:meth:`ResponseSurface.at_radius`): its
        depths (mm) are the ratios h/R.

        Parameters
        ----------
        depth_ratio_max : float
            Largest h/R (default 0.5), i.e. largest depth (mm) at R = 1 mm.
        n_depth : int
            Number of depths, equally spaced from ``depth_ratio_max / n_depth``.
        E_kPa : array_like, optional
            E nodes (kPa). Default 10 values geometric from 1e-4 to 1e5 kPa (0.1 Pa to
            100 MPa: cells and gels to stiff tissue); F is exactly linear in E, so the
            E axis only sets the admissible box.
        nu : array_like, optional
            nu nodes. Default 6 values from 0.2 to 0.499: the finite-element law is
            compressible (nu < 0.5), and 0.499 is the nearly incompressible end that
            AFM users ask for with "nu = 0.5" (E / (1 - nu^2) differs by 0.13%).
        """
        if not (np.isfinite(depth_ratio_max) and depth_ratio_max > 0):
            raise ValueError(f"depth_ratio_max must be a finite number > 0, got {depth_ratio_max}")
        return cls(
            depth_mm=np.linspace(depth_ratio_max / n_depth, depth_ratio_max, n_depth),
            E_kPa=np.geomspace(1e-4, 1e5, 10) if E_kPa is None else E_kPa,
            nu=np.linspace(0.2, 0.499, 6) if nu is None else nu,
        )

    def scaled_depths(self, factor: float) -> "SurfaceGrid":
        """The same grid with every depth multiplied by ``factor`` (> 0)."""
        if not (np.isfinite(factor) and factor > 0):
            raise ValueError(f"depth scale factor must be a finite number > 0, got {factor}")
        return SurfaceGrid(self.depth_mm * factor, self.E_kPa, self.nu)

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(n_depth, n_E, n_nu)``."""
        return (self.depth_mm.size, self.E_kPa.size, self.nu.size)

    def to_dict(self) -> dict:
        """Plain lists (for JSON and hashing)."""
        return {k: getattr(self, k).tolist() for k in ("depth_mm", "E_kPa", "nu")}

    def __eq__(self, other):
        if not isinstance(other, SurfaceGrid):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    def __hash__(self):
        return hash(tuple(getattr(self, k).tobytes() for k in ("depth_mm", "E_kPa", "nu")))

    def __repr__(self):
        parts = (f"{k}=[{a[0]:g} .. {a[-1]:g}] ({a.size})" for k, a in
                 (("depth_mm", self.depth_mm), ("E_kPa", self.E_kPa), ("nu", self.nu)))
        return f"SurfaceGrid({', '.join(parts)})"


#: the depth ranges surfaces are built for, per decade (mm): curves share surfaces and runs
NICE_DEPTHS = (1.0, 1.25, 1.6, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0)


def nice_depth(depth_mm: float) -> float:
    """The smallest of :data:`NICE_DEPTHS` x 10^k that reaches ``depth_mm`` (mm)."""
    if not (math.isfinite(depth_mm) and depth_mm > 0):
        raise ValueError(f"the curve reaches no positive depth (got {depth_mm} mm)")
    k = math.floor(math.log10(depth_mm))
    for m in (*NICE_DEPTHS, 10.0):
        top = float(f"{m * 10.0**k:.6g}")
        if top >= depth_mm * (1 - 1e-12):
            return top
    raise AssertionError("unreachable")  # pragma: no cover
