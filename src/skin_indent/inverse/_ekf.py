"""The extended Kalman filter both filters of :mod:`.kalman` run, and its sweeps.

A static state (F = I, process noise Q = 0 unless given), one scalar measurement per
point (R), points taken forward on odd sweeps and backward on even ones
(:func:`sweep_order`), and what the sweeps record (:class:`SweepRecorder`).
"""

from __future__ import annotations

import numpy as np


class SweepRecorder:
    """Preallocated histories (first forward pass, end of sweeps, last-sweep innovations)."""

    def __init__(self, n: int, p: int, max_sweeps: int):
        self.first = np.full((n, p), np.nan)
        self.first_cov = np.full((n, p, p), np.nan)
        self.sweeps = np.full((max_sweeps + 1, p), np.nan)
        self.sweep_cov = np.full((max_sweeps + 1, p, p), np.nan)
        self.innovation = np.full(n, np.nan)
        self.innovation_var = np.full(n, np.nan)

    def history(self, k: int) -> dict[str, np.ndarray]:
        first_std = np.sqrt(np.maximum(np.diagonal(self.first_cov, axis1=1, axis2=2), 0.0))
        sweep_std = np.sqrt(np.maximum(np.diagonal(self.sweep_cov[: k + 1], axis1=1, axis2=2), 0.0))
        return {
            "first_pass": self.first, "first_pass_std": first_std, "first_pass_covariance": self.first_cov,
            "sweeps": self.sweeps[: k + 1], "sweep_std": sweep_std, "sweep_covariance": self.sweep_cov[: k + 1],
            "innovation": self.innovation, "innovation_var": self.innovation_var,
        }


def make_filter(p: int, R: float):
    """A :class:`filterpy.kalman.ExtendedKalmanFilter` with F = I, R and Q = 0."""
    from filterpy.kalman import ExtendedKalmanFilter  # lazy: filterpy imports most of scipy

    kf = ExtendedKalmanFilter(dim_x=p, dim_z=1)
    kf.F = np.eye(p)
    kf.R = np.array([[R]])
    kf.Q = np.zeros((p, p))
    return kf


def sweep_order(n: int, sweep: int) -> range:
    """Odd sweeps forward (shallow -> deep), even sweeps backward."""
    return range(n) if sweep % 2 == 1 else range(n - 1, -1, -1)
