"""Test fixtures: data paths inside the project (tests/data), the only data a user's clone has."""

import pytest
from _data import load_curve


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
