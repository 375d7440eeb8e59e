"""Shared checks of constitutive laws: random displacement gradients and finite differences."""

import numpy as np


def random_H(n=7, scale=0.2, seed=0, axisymmetric=True):
    """Displacement gradients; axisymmetric ones have zero r-theta and z-theta components."""
    H = scale * np.random.default_rng(seed).standard_normal((3, 3, n))
    if axisymmetric:
        H[0, 2] = H[2, 0] = H[1, 2] = H[2, 1] = 0.0
    return H


def finite_differences(law, H, eps=1e-6):
    """Central differences of the energy (-> P) and of the stress (-> A)."""
    P_fd = np.zeros_like(H)
    A_fd = np.zeros((3, 3) + H.shape)
    for k in range(3):
        for L in range(3):
            dH = np.zeros_like(H)
            dH[k, L] = eps
            P_fd[k, L] = (law.energy(H + dH) - law.energy(H - dH)) / (2 * eps)
            A_fd[:, :, k, L] = (law.stress(H + dH) - law.stress(H - dH)) / (2 * eps)
    return P_fd, A_fd
