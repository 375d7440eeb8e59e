"""Settings, cache keys, default forward model and atomic files."""

from __future__ import annotations

import functools
import hashlib
import json
import os
import socket
import time
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from ..runtime.atomic import atomic_write
from ._grid import SurfaceGrid
from skin_indent import __version__

UnitCurve = Callable[[float, np.ndarray], np.ndarray]


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"settings value {obj!r} of type {type(obj).__name__} is not JSON-serialisable")


def canonical_json(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=_json_default, allow_nan=False)


def settings_hash(settings: Mapping, grid: SurfaceGrid) -> str:
    """SHA-256 (hex) of the canonical JSON of ``settings`` and ``grid``: the cache key."""
    return hashlib.sha256(canonical_json({"settings": settings, "grid": grid.to_dict()}).encode()).hexdigest()


def run_key(settings: Mapping, depth_mm: np.ndarray) -> str:
    # a forward run depends on the settings, the depths and nu, not on the E grid
    payload = {"settings": settings, "depth_mm": np.asarray(depth_mm).tolist()}
    return hashlib.sha256(canonical_json(payload).encode()).hexdigest()


def source_digest() -> str:
    """Digest of the forward-model sources, so that editing them invalidates caches."""
    root = Path(__file__).parent.parent  # the skin_indent package
    files = sorted([root / "simulate.py", *(root / "mechanics").rglob("*.py")])
    h = hashlib.sha256()
    for p in files:
        if p.is_file():
            h.update(p.relative_to(root).as_posix().encode() + b"\0" + p.read_bytes())
    return h.hexdigest()[:12]


def default_settings(radius_mm: float = 6.22, mesh: str = "medium") -> dict:
    """Settings of the default finite-element unit curve.

    ``code_version`` is the package version plus a digest of ``simulate.py`` and
    ``mechanics/``, so that a change of the forward model invalidates cached surfaces.

    Parameters
    ----------
    radius_mm : float
        Sphere radius R (mm).
    mesh : str
        Mesh preset passed to :func:`skin_indent.simulate.fe_unit_curve`.
    """
    return {
        "model": "neo-hooke half-space",
        "unit_curve": "skin_indent.simulate.fe_unit_curve",
        "radius_mm": float(radius_mm),
        "mesh": mesh,
        "code_version": f"{__version__}+src.{source_digest()}",
    }


def _fe_unit_curve(nu: float, depth_mm: np.ndarray, **kwargs) -> np.ndarray:
    from skin_indent.simulate import fe_unit_curve  # lazy: mechanics is heavy

    return fe_unit_curve(nu, depth_mm, **kwargs)


def default_unit_curve(settings: Mapping | None = None) -> functools.partial:
    """Picklable FE unit curve ``(nu, depth_mm) -> force_mN at E = 1 kPa``.

    Parameters
    ----------
    settings : mapping, optional
        Must hold ``radius_mm`` (mm) and ``mesh``; default :func:`default_settings`.
    """
    settings = default_settings() if settings is None else settings
    try:
        kwargs = {"radius_mm": float(settings["radius_mm"]), "mesh": settings["mesh"]}
    except KeyError as exc:
        raise ValueError(f"settings for the FE unit curve need key {exc.args[0]!r}") from None
    return functools.partial(_fe_unit_curve, **kwargs)


def _describe_callable(fn) -> dict:
    if isinstance(fn, functools.partial):
        return {"func": _describe_callable(fn.func), "args": repr(fn.args), "kwargs": repr(sorted(fn.keywords.items()))}
    kind = fn if hasattr(fn, "__qualname__") else type(fn)  # a callable instance: its class
    return {"func": f"{getattr(kind, '__module__', '?')}.{kind.__qualname__}"}


def resolve_model(unit_curve: UnitCurve | None, settings: Mapping | None):
    """``(unit_curve, settings)`` with defaults filled in; settings as canonical JSON data."""
    if unit_curve is None:
        settings = default_settings() if settings is None else settings
        unit_curve = default_unit_curve(settings)
    elif settings is None:
        settings = {"unit_curve": _describe_callable(unit_curve)}
    return unit_curve, json.loads(canonical_json(settings))


def default_cache_dir() -> Path:
    """``$SKIN_INDENT_CACHE`` if set, else ``~/.cache/skin_indent``."""
    env = os.environ.get("SKIN_INDENT_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "skin_indent"




def atomic_savez(path: Path, **arrays) -> None:
    atomic_write(path, lambda fh: np.savez(fh, **arrays))


def _run_one(unit_curve: UnitCurve, nu: float, depth_mm: np.ndarray):
    """One forward run, in a worker process: ``(nu, forces or None, reason or None)``."""
    try:
        f = np.asarray(unit_curve(float(nu), depth_mm.copy()), dtype=float)
    except Exception as exc:  # recorded, not raised: the column is marked missing
        return nu, None, f"{type(exc).__name__}: {exc}"
    if f.shape != depth_mm.shape:
        return nu, None, f"unit curve returned shape {f.shape}, expected {depth_mm.shape}"
    if not np.all(np.isfinite(f)):
        return nu, None, "unit curve returned non-finite forces"
    return nu, f, None


def run_task(unit_curve: UnitCurve, nu: float, depth_mm: np.ndarray) -> dict:
    """:func:`_run_one` plus where and how long it ran, and the digest of the forward-model
    sources installed there (~0.4 ms: read afresh for every run)."""
    t, cpu = time.perf_counter(), time.thread_time()
    nu, f, reason = _run_one(unit_curve, nu, depth_mm)
    return {"nu": nu, "values": f, "reason": reason, "seconds": time.perf_counter() - t,
            "cpu_seconds": time.thread_time() - cpu, "worker": f"{socket.gethostname()}:{os.getpid()}",
            "code": source_digest()}


def expected_code_of(settings: Mapping) -> str | None:
    """The source digest that ``settings`` claim (``code_version`` of :func:`default_settings`)."""
    version = settings.get("code_version") if isinstance(settings, Mapping) else None
    if isinstance(version, str) and "+src." in version:
        return version.rsplit("+src.", 1)[1]
    return None
