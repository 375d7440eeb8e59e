"""Shared test fixtures: data paths (never ../shared: a user's clone has no such folder)."""

from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).parent / "data"


def load_curve(relpath: str) -> np.ndarray:
    """Columns of a CSV in tests/data (header skipped)."""
    return np.loadtxt(DATA / relpath, delimiter=",", skiprows=1)


@pytest.fixture(scope="session")
def reference_curves():
    """The independent FE reference curves: {(E, nu): (depth_mm, force_mN)} without the h = 0 row."""
    out = {}
    for (E, nu), name in {(8.0, 0.45): "neo-hooke_halfspace_E8kPa_nu0.45.csv",
                          (5.0, 0.48): "neo-hooke_halfspace_E5kPa_nu0.48.csv"}.items():
        data = load_curve(f"reference/{name}")
        data = data[data[:, 0] > 0]
        out[(E, nu)] = (data[:, 0], data[:, 1])
    return out
