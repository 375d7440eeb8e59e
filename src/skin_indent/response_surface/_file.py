"""A response surface's file: npz arrays with JSON metadata, written atomically and checked on reading.

:func:`save_surface` and :func:`load_surface` are :meth:`ResponseSurface.save
<skin_indent.response_surface.ResponseSurface.save>` and :meth:`~skin_indent.response_surface.ResponseSurface.load`;
a damaged or edited file is refused with one line that names it.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ._cache import atomic_savez, canonical_json
from ._grid import SurfaceGrid

_FORMAT = "skin_indent.response_surface"
_FORMAT_VERSION = 1


def save_surface(surface, path: str | os.PathLike) -> Path:
    """Write ``surface`` (a :class:`~skin_indent.response_surface.ResponseSurface`) to ``path``."""
    meta = {"format": _FORMAT, "version": _FORMAT_VERSION, "hash": surface.hash, "settings": surface.settings,
            "failures": [[nu, why] for nu, why in surface.failures.items()],
            "options": {"method": surface.method, "depth_interp": surface.depth_interp, "scaling": surface.scaling}}
    path = Path(path)
    atomic_savez(path, depth_mm=surface.grid.depth_mm, E_kPa=surface.grid.E_kPa, nu=surface.grid.nu,
                  unit_force_mN=surface._f, meta=np.array(canonical_json(meta)))
    return path


def load_surface(cls, path: str | os.PathLike, **options):
    """Read a surface of class ``cls`` from ``path``; ``options`` override the stored interpolation options.

    Raises
    ------
    OSError
        The file is missing or unreadable.
    ValueError
        Not a response surface file of this format, damaged, or its stored hash does not match its
        settings and grid.
    """
    path = Path(path)
    with open(path, "rb") as fh:  # OSError (missing, a directory, no permission) as it is
        magic = fh.read(4)
    try:
        if magic[:2] != b"PK":
            raise ValueError("not an npz archive")
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            arrays = {k: np.array(z[k]) for k in ("depth_mm", "E_kPa", "nu", "unit_force_mN")}
        if not isinstance(meta, dict):
            raise ValueError("metadata is not a JSON object")
    except Exception as err:  # noqa: BLE001 - any damage: one line that names the file
        why = " ".join(str(err).split()) or type(err).__name__
        raise ValueError(f"{path}: not a readable response surface file ({why})") from None
    if meta.get("format") != _FORMAT or meta.get("version") != _FORMAT_VERSION:
        raise ValueError(f"{path}: not a response surface of format version {_FORMAT_VERSION}")
    try:
        grid = SurfaceGrid(arrays["depth_mm"], arrays["E_kPa"], arrays["nu"])
        out = cls(grid, arrays["unit_force_mN"], settings=meta["settings"], failures=dict(meta["failures"]),
                  **{**meta["options"], **options})
        stored_hash = str(meta["hash"])
    except (ValueError, TypeError, KeyError) as err:
        why = " ".join(str(err).split()) or type(err).__name__
        raise ValueError(f"{path}: damaged response surface file ({why})") from None
    if out.hash != stored_hash:
        raise ValueError(f"{path}: stored hash does not match its settings and grid (file edited?)")
    return out
