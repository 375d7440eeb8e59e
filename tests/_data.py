"""Test data access: everything lives in tests/data, inside the project (a user's clone has nothing else)."""

from pathlib import Path

import numpy as np

DATA = Path(__file__).parent / "data"


def load_curve(relpath: str) -> np.ndarray:
    """Columns of a CSV in tests/data (header skipped)."""
    return np.loadtxt(DATA / relpath, delimiter=",", skiprows=1)
