"""Several prepared curves of one sample, seen as one set of points.

A real protocol measures one site several ways: two spheres, two depths, two speeds, a
ramp and a ramp-hold. Each curve keeps everything that belongs to its recording (its
sphere radius, contact point, baseline, noise, time history); what the curves share is
the sample. :class:`CurveSet` holds the curves in input order and shows their points
concatenated, which is what a joint fit compares with a joint model
(:class:`~skin_indent.models.JointModel`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._errors import MeasurementError
from .preparation import PreparedCurve


@dataclass(frozen=True, eq=False)
class CurveSet:
    """The prepared curves of one sample, in input order.

    Attributes
    ----------
    curves : tuple of PreparedCurve
        At least two.

    Notes
    -----
    ``depth_mm``, ``force_mN`` and ``kind`` are the curves' points concatenated in input
    order (``slices`` says where each curve's are); the recorded depths of different
    curves are not on one axis (each has its own contact point), so there is no joint
    time axis either: per-curve work goes through ``curves``.
    """

    curves: tuple

    def __post_init__(self):
        curves = tuple(self.curves)
        if len(curves) < 2:
            raise MeasurementError("a set of curves of one sample needs at least two curves")
        for c in curves:
            if not isinstance(c, PreparedCurve):
                raise TypeError(f"a CurveSet holds prepared curves, got {type(c).__name__}")
        object.__setattr__(self, "curves", curves)

    def __len__(self) -> int:
        return len(self.curves)

    def __iter__(self):
        return iter(self.curves)

    def __getitem__(self, k: int) -> PreparedCurve:
        return self.curves[k]

    @property
    def source(self) -> str:
        """The curves' sources joined by ``" + "``."""
        return " + ".join(c.source for c in self.curves)

    @property
    def sources(self) -> list[str]:
        return [c.source for c in self.curves]

    @property
    def n(self) -> int:
        return sum(c.n for c in self.curves)

    @property
    def slices(self) -> list[slice]:
        """Each curve's points in the concatenation."""
        stops = np.cumsum([0] + [c.n for c in self.curves])
        return [slice(int(a), int(b)) for a, b in zip(stops[:-1], stops[1:])]

    @property
    def depth_mm(self) -> np.ndarray:
        return np.concatenate([c.depth_mm for c in self.curves])

    @property
    def force_mN(self) -> np.ndarray:
        return np.concatenate([c.force_mN for c in self.curves])

    @property
    def kind(self) -> np.ndarray:
        return np.concatenate([c.kind for c in self.curves])

    @property
    def radius_mm(self) -> float:
        """The first curve's sphere radius (mm); each curve has its own (``radii_mm``)."""
        return float(self.curves[0].radius_mm)

    @property
    def radii_mm(self) -> list[float]:
        return [float(c.radius_mm) for c in self.curves]

    @property
    def max_indentation_mm(self) -> float:
        """The deepest indentation of any curve past its contact guess (mm)."""
        return max(c.max_indentation_mm for c in self.curves)

    def has(self, kind: str) -> bool:
        return any(c.has(kind) for c in self.curves)

    def split(self, values) -> list[np.ndarray]:
        """A per-point array of the concatenation, cut into the curves' parts."""
        values = np.asarray(values)
        return [values[s] for s in self.slices]
