"""Data files shipped with the package, so an installed copy can run its demo.

- ``forearm_like.csv``: a forearm-like indentation curve (``time_s,depth_mm,force_mN``,
  sphere R = 6.22 mm, loading to 0.6 mm) computed with an independent FE code
  (FElupe) for a layered skin model, with sensor-like noise. Not a measurement.
- ``forearm_like_exact.csv``: the same curve without noise.
- ``README.md``: how the curves were made and the model behind them.

Use :func:`bundled_path` to get a file's path, e.g.
``load_csv(bundled_path("forearm_like.csv"))``.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["bundled_path", "bundled_names"]

_HERE = Path(__file__).parent


def bundled_names() -> list[str]:
    """Names of the bundled data files (sorted)."""
    return sorted(p.name for p in _HERE.iterdir()
                  if p.is_file() and p.suffix in {".csv", ".md"})


def bundled_path(name: str) -> Path:
    """Path of a bundled data file.

    Parameters
    ----------
    name : str
        A file name from :func:`bundled_names`, e.g. ``"forearm_like.csv"``.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        If `name` is not a bundled file (the message lists the available ones).
    """
    names = bundled_names()
    if name not in names:
        raise ValueError(
            f"unknown bundled data file {name!r}; available: {', '.join(names)}"
        )
    return _HERE / name
