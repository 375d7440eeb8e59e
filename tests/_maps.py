"""Synthetic force maps: curves of the forward model written as one multi-curve instrument file.

:func:`write_force_map` writes curves (depth in mm, force in mN, time in s) into one HDF5 file in
afmformats' format (afmformats and h5py, the ``afm`` extra), with the grid indices and positions
of a force map: :func:`skin_indent.measurement.load_curves` reads them back as the curves of a
map, as it reads a JPK ``.jpk-force-map``. Used by tests/test_diagnose_batch.py and
benchmarks/diagnose_batch.py.
"""

from __future__ import annotations

import numpy as np


def write_force_map(path, curves, nx: int, *, pitch_mm: float = 0.5) -> None:
    """Write ``curves`` as a force map of ``nx`` columns (row by row), ``pitch_mm`` apart.

    Parameters
    ----------
    path : path
        The ``.h5`` file (overwritten).
    curves : sequence of (depth_mm, force_mN, time_s)
        Depth positive into the sample from the first sample, force in mN, time in s.
    nx : int
        Curves per row of the map.
    pitch_mm : float
        Distance between neighbouring map points (mm).
    """
    import h5py
    from afmformats import AFMForceDistance

    ny = -(-len(curves) // nx)
    with h5py.File(path, "w") as h5:
        for k, (depth, force, time) in enumerate(curves):
            depth = np.asarray(depth, dtype=float)
            meta = {"path": str(path), "enum": k, "imaging mode": "force-distance", "point count": depth.size,
                    "grid index x": k % nx, "grid index y": k // nx, "grid shape x": nx, "grid shape y": ny,
                    "position x": (k % nx) * pitch_mm * 1e-3, "position y": (k // nx) * pitch_mm * 1e-3}
            data = {"force": np.asarray(force, dtype=float) * 1e-3, "tip position": -depth * 1e-3,
                    "segment": np.zeros(depth.size, dtype=np.uint8), "time": np.asarray(time, dtype=float)}
            AFMForceDistance(data, meta).export_data(h5, fmt="hdf5")


def forward_curve(E_kPa: float, *, contact_mm: float = 0.0, C20_kPa: float = 0.0, depth_mm: float = 0.6,
                  radius_mm: float = 6.22, noise_mN: float = 0.05, seed: int = 0, points: int = 100):
    """A recorded-like loading curve of the forward model (coarse mesh, nu = 0.45): ``points`` depths
    from 0 to ``depth_mm`` at 0.02 mm/s, contact at ``contact_mm`` (zero force before it), a Yeoh
    term ``C20_kPa`` (strain stiffening) when given, Gaussian noise of ``noise_mN``.

    Returns
    -------
    depth_mm, force_mN, time_s : ndarray
    """
    from skin_indent import NeoHooke, NeoHookeStiffening, SphericalIndenter, simulate

    depth = np.linspace(0.0, depth_mm, points)
    h = depth - contact_mm
    touching = h > 1e-9
    material = NeoHookeStiffening(E_kPa, 0.45, C20_kPa) if C20_kPa else NeoHooke(E_kPa=E_kPa, nu=0.45)
    force = np.zeros(points)
    force[touching] = simulate(material, SphericalIndenter(radius_mm=radius_mm), h[touching],
                               mesh="coarse").force_mN
    force += np.random.default_rng(seed).normal(0.0, noise_mN, points)
    return depth, force, depth / 0.02
