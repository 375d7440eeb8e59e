"""The curve as diagnosed: segments, baseline, contact guess, binning, noise, depth ranges."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..inverse import estimate_noise
from ..measurement import Measurement

#: at most this many points are fitted (longer curves are averaged in bins, in time order)
MAX_POINTS = 400

@dataclass(frozen=True)
class DiagnosisData:
    """The curve as diagnosed: in contact coordinates, binned to at most MAX_POINTS.

    Attributes
    ----------
    depth_mm, force_mN : ndarray
        Depth (mm) and force (mN) in time order.
    time_s : ndarray or None
    kind : ndarray of str
        ``"approach"``, ``"hold"`` or ``"retract"`` per point.
    source : str
    binned : int
        Points averaged per bin (1: none).
    baseline_mN : float
        Force offset removed (0 when the curve has no pre-contact part).
    contact_guess_mm : float
        First guess of the contact point in recorded depth (0: curve starts at contact).
    """

    depth_mm: np.ndarray
    force_mN: np.ndarray
    time_s: np.ndarray | None
    kind: np.ndarray
    source: str
    binned: int = 1
    baseline_mN: float = 0.0
    contact_guess_mm: float = 0.0

    @property
    def n(self) -> int:
        return self.depth_mm.size

    def has(self, kind: str) -> bool:
        return bool(np.any(self.kind == kind))


SEGMENTS = ("approach", "hold", "retract")


def prepare(measurement: Measurement, max_points: int = MAX_POINTS, segments=SEGMENTS) -> DiagnosisData:
    """Segments, baseline, contact guess and binning of a measurement (see :class:`DiagnosisData`).

    ``segments`` keeps only those kinds of motion (e.g. leave out a retract dominated by
    tethers); the history before the last kept point is kept whole, since a viscoelastic
    force depends on it, so only trailing segments can be left out.
    """
    bad = set(segments) - set(SEGMENTS)
    if bad or not segments:
        raise ValueError(f"segments must be among {', '.join(SEGMENTS)}, got {', '.join(segments) or 'none'}")
    from ..measurement import find_contact_point, find_segments

    m = measurement
    kinds = np.empty(m.n_points, dtype=object)
    if m.has_time:
        for seg in find_segments(m):
            kinds[seg.start:seg.stop] = seg.kind
    else:
        kinds[:] = "approach"
    baseline, contact = 0.0, 0.0
    try:
        cp = find_contact_point(m)
    except Exception:  # noqa: BLE001 - no pre-contact part to speak of
        cp = None
    # a pre-contact part worth the name: contact beyond 30% of the recorded travel (AFM curves
    # approach from far away: 50-90%); a skin curve whose first forces hide in the noise, or whose
    # contact point is slightly off, keeps its origin, and the ``offset`` candidate tests the shift
    if (cp is not None and cp.has_baseline and cp.baseline is not None
            and cp.depth_mm > 0.3 * float(np.max(m.depth_mm))):
        line = cp.baseline if cp.baseline.tilt_significant else cp.baseline.flat()
        baseline = float(line.force_at(cp.depth_mm))
        contact = float(cp.depth_mm)
    keep = np.isin(kinds.astype(str), list(segments))
    if not np.any(keep):
        raise ValueError(f"{m.source}: no {' or '.join(segments)} segment in this curve")
    last = int(np.flatnonzero(keep)[-1]) + 1
    dropped = sorted(set(kinds[:last].astype(str)) - set(segments))
    if dropped:
        raise ValueError(f"leaving out {', '.join(dropped)} would cut the history before a kept segment: "
                         "only trailing segments can be left out")
    kinds = kinds[:last]
    depth, force = np.array(m.depth_mm[:last]), np.array(m.force_mN[:last]) - baseline
    time = None if m.time_s is None else np.array(m.time_s[:last])
    n = depth.size
    k = max(1, math.ceil(n / max_points))
    if k > 1:  # bin within segments so that a bin never straddles a turn
        rows = []
        start = 0
        for i in range(1, n + 1):
            if i == n or kinds[i] != kinds[start] or i - start == k:
                rows.append((start, i))
                start = i
        depth = np.array([depth[a:b].mean() for a, b in rows])
        force = np.array([force[a:b].mean() for a, b in rows])
        time = None if time is None else np.array([time[a:b].mean() for a, b in rows])
        kinds = np.array([kinds[a] for a, _ in rows], dtype=object)
    return DiagnosisData(depth, force, time, kinds.astype(str), m.source, k, baseline, contact)


def estimate_data_noise(data: DiagnosisData) -> float:
    """Noise (mN) from the data: local cubic prediction along time (or depth) order."""
    x = data.time_s if data.time_s is not None and np.all(np.diff(data.time_s) > 0) else np.arange(data.n, dtype=float)
    sigma = estimate_noise(x, data.force_mN)
    if not sigma > 0:
        raise ValueError("cannot estimate the noise from a noise-free curve: give the noise level (--noise)")
    return float(sigma)


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
