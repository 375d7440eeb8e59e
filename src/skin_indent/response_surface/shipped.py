"""Response surfaces shipped with the package, verified by their forces, read like the run cache.

A fresh install has an empty run cache, and the surfaces of its first workflows (the demo's,
a skin curve's diagnosis) would cost hundreds of finite-element runs before any fit. The runs
of those surfaces are computed once (``benchmarks/build_shipped_surfaces.py``) and shipped in
``skin_indent/data/surfaces/``:

- ``index.json``: for every surface (one set of forward runs, a run per nu, all at the same
  depths) its settings without ``code_version``, its nu and the file and arrays that hold its
  forces; ``made_with``: the package version and the forward-model source digest that made
  them; ``verified_code``: the source digests the forces were verified against;
- one ``.npz`` per family of surfaces (a model at one radius and mesh, e.g. the dimensionless
  layer surfaces of every depth ceiling at R = 1 mm): depths, nu and unit forces (mN at
  E = 1 kPa) of every surface, float64, as the runs returned them.

Reading
-------
:class:`~skin_indent.response_surface.RunStore` asks :func:`lookup` for a run its manifest
does not list: a shipped run whose settings (``code_version`` aside), depths and nu equal the
store's is returned as if it were cached. The run key of the cache includes the source digest
of the forward model (``code_version``); the shipped runs are found by the same key without it,
and **accepted only if the store's digest is one of** ``verified_code``. Otherwise they are
ignored (one INFO line per process, naming both digests) and the surface is built as without
them.

Verification by forces, not by digest alone
-------------------------------------------
A change of the mechanics changes the source digest whether or not it moves the forces.
:func:`verify` recomputes a sample of every family's runs with the installed forward model and
compares them with the shipped forces: every force must agree within :data:`TOLERANCE`, a
tenth of the model error the fits allow (0.3 % of F). ``benchmarks/build_shipped_surfaces.py
verify --stamp`` then adds the installed digest to ``verified_code`` (:func:`stamp`): a change
that does not move the forces costs a few runs and a stamp, not a rebuild; one that moves them
fails the check (rebuild). The test ``tests/test_shipped_surfaces.py`` makes the same check in
the default test run, shows that it fails on a node perturbed by 0.1 %, and fails while the
installed digest is not stamped (the shipped surfaces would then be ignored).
"""

from __future__ import annotations

import datetime as _dt
import functools
import hashlib
import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from ..runtime.atomic import atomic_write
from ._cache import canonical_json, expected_code_of, run_key, source_digest
from ._store import npz_bytes

log = logging.getLogger(__name__)

__all__ = ["SHIPPED_DIR", "TOLERANCE", "lookup", "ships", "verify", "stamp", "export_cache", "physics_key"]

#: where the shipped surfaces are (package data)
SHIPPED_DIR = Path(__file__).resolve().parent.parent / "data" / "surfaces"
INDEX = "index.json"
_FORMAT = "skin_indent.shipped_surfaces"
_VERSION = 1
#: largest relative force difference a verified shipped run may have: a tenth of the model
#: error of the fits (:data:`skin_indent.fitting.rung.MODEL_ERROR`, 0.3 % of F)
TOLERANCE = 0.1 * 0.003


def physics_key(settings: Mapping, depth_mm) -> str:
    """The run key of :func:`run_key` without ``code_version``: what a shipped run is found by."""
    bare = {k: v for k, v in json.loads(canonical_json(settings)).items() if k != "code_version"}
    return run_key(bare, np.asarray(depth_mm, dtype=float))


# ------------------------------------------------------------------ reading
class _Shipped:
    """The index and arrays of one folder of shipped surfaces (read once, lazily)."""

    def __init__(self, directory: Path):
        self.dir = Path(directory)
        try:
            index = json.loads((self.dir / INDEX).read_text(encoding="utf-8"))
            ok = index.get("format") == _FORMAT and index.get("version") == _VERSION
        except (OSError, ValueError, AttributeError):
            index, ok = {}, False
        self.index = index if ok else {"surfaces": [], "verified_code": []}
        self.verified = set(self.index.get("verified_code", []))
        self.by_key = {s["key"]: s for s in self.index["surfaces"]}
        self._files: dict[str, dict] = {}
        self.warned = False

    def arrays(self, name: str) -> dict | None:
        """The arrays of a shipped file, if its bytes have the listed checksum."""
        if name not in self._files:
            path = self.dir / name
            arrays = None
            try:
                raw = path.read_bytes()
                if hashlib.sha256(raw).hexdigest() == self.index.get("files", {}).get(name):
                    with np.load(path, allow_pickle=False) as z:
                        arrays = {k: np.array(z[k]) for k in z.files}
            except (OSError, ValueError):
                arrays = None
            if arrays is None:
                log.warning("shipped response surface file %s is missing or damaged: not used", path)
            self._files[name] = arrays
        return self._files[name]

    def find(self, settings: Mapping, depth_mm: np.ndarray, nu: float, key: str | None = None):
        entry = self.by_key.get(key if key is not None else physics_key(settings, depth_mm))
        if entry is None:
            return None
        code = expected_code_of(settings)
        if code not in self.verified:
            if not self.warned:
                self.warned = True
                log.info("the shipped response surfaces are verified for forward-model sources %s, the installed "
                         "ones are src.%s: not used, surfaces are built (`python benchmarks/"
                         "build_shipped_surfaces.py verify --stamp` accepts them if their forces hold)",
                         ", ".join(f"src.{c}" for c in sorted(self.verified)) or "none", code)
            return None
        arrays = self.arrays(entry["file"])
        if arrays is None:
            return None
        nus = arrays[f"{entry['array']}_nu"]
        hit = np.flatnonzero(nus == float(nu))
        if hit.size != 1 or not np.array_equal(arrays[f"{entry['array']}_depth_mm"], depth_mm):
            return None
        return np.array(arrays[f"{entry['array']}_f"][hit[0]], dtype=float)


@functools.lru_cache(maxsize=4)
def _shipped(directory: str) -> _Shipped:
    return _Shipped(Path(directory))


def lookup(settings: Mapping, depth_mm, nu: float, *, key: str | None = None,
           directory: Path | None = None) -> np.ndarray | None:
    """The shipped unit forces (mN at E = 1 kPa) of a run, or None.

    Parameters
    ----------
    settings : mapping
        The run's settings (with ``code_version``: its digest must be a verified one).
    depth_mm : numpy.ndarray
        The run's depths (mm).
    nu : float
        Its Poisson's ratio.
    key : str, optional
        :func:`physics_key` of ``settings`` and ``depth_mm``, if known.
    directory : path, optional
        The shipped surfaces (default :data:`SHIPPED_DIR`).
    """
    return _shipped(str(SHIPPED_DIR if directory is None else directory)).find(
        settings, np.asarray(depth_mm, dtype=float), nu, key)


def ships(settings: Mapping, depth_mm, *, directory: Path | None = None) -> bool:
    """Whether the package ships the runs of a surface with these settings (``code_version``
    aside) and depths: a property of the package, whether or not they are verified for the
    installed forward model (:func:`lookup` says that)."""
    key = physics_key(settings, np.asarray(depth_mm, dtype=float))
    return key in _shipped(str(SHIPPED_DIR if directory is None else directory)).by_key


# ------------------------------------------------------------------ verification
@dataclass(frozen=True)
class Check:
    """One shipped run recomputed: its surface, nu and largest relative force difference."""

    label: str
    nu: float
    difference: float

    @property
    def ok(self) -> bool:
        return bool(self.difference <= TOLERANCE)


@dataclass(frozen=True)
class Report:
    """The checks of :func:`verify`."""

    checks: tuple
    code: str

    @property
    def ok(self) -> bool:
        return bool(self.checks) and all(c.ok for c in self.checks)

    def lines(self) -> list[str]:
        out = [f"{c.label}, nu = {c.nu:g}: largest force difference {c.difference:.2e} "
               f"({'ok' if c.ok else 'FAILS'}, tolerance {TOLERANCE:.0e})" for c in self.checks]
        return out + [f"{len(self.checks)} shipped runs recomputed with src.{self.code}: "
                      f"{'all within' if self.ok else 'NOT all within'} a tenth of the model error"]


def relative_difference(shipped: np.ndarray, recomputed: np.ndarray) -> float:
    """Largest ``|recomputed - shipped| / |shipped|`` over the depths (inf if a force is not finite)."""
    shipped, recomputed = np.asarray(shipped, float), np.asarray(recomputed, float)
    if shipped.shape != recomputed.shape or not np.all(np.isfinite(recomputed)):
        return float("inf")
    return float(np.max(np.abs(recomputed - shipped) / np.abs(shipped)))


def sample_runs(sample: int = 1, directory: Path | None = None) -> list[tuple]:
    """``(label, settings, depth_mm, nu, shipped forces)`` of ``sample`` runs of every family (file).

    A family is the surfaces of one model, radius and mesh, as exported (one or several depth
    ranges; one surface per depth range, or one per node of an effect surface's axes). Its
    surfaces are taken at evenly spaced places of its list (in order of their unit parameters,
    then depth range: for ``sample=1`` the middle one, e.g. the centre node of a layer
    surface's 7 x 7; for 2 the first and the last), each at its middle nu node: the same runs
    every time, so that the test and the script check the same.
    """
    d = Path(SHIPPED_DIR if directory is None else directory)
    shipped = _Shipped(d)
    families: dict[str, list] = {}
    for entry in shipped.index["surfaces"]:
        families.setdefault(entry["file"], []).append(entry)
    out = []
    for name, entries in sorted(families.items()):
        arrays = shipped.arrays(name)
        if arrays is None:
            raise ValueError(f"shipped response surface file {d / name} is missing or damaged")
        picks = [len(entries) // 2] if sample <= 1 else np.unique(
            np.round(np.linspace(0, len(entries) - 1, sample)).astype(int)).tolist()
        for i in picks:
            e = entries[i]
            nus = arrays[f"{e['array']}_nu"]
            j = nus.size // 2
            out.append((e["label"], e["settings"], arrays[f"{e['array']}_depth_mm"], float(nus[j]),
                        arrays[f"{e['array']}_f"][j]))
    return out


def verify(sample: int | None = None, *, forces_of: Callable, directory: Path | None = None) -> Report:
    """Recompute ``sample`` runs of every shipped family and compare their forces (see the module docstring).

    Parameters
    ----------
    sample : int, optional
        Runs per family (default 1).
    directory : path, optional
        The shipped surfaces (default :data:`SHIPPED_DIR`).
    forces_of : callable
        ``forces_of(settings, depth_mm, nu) -> unit forces``: the installed forward model,
        :func:`skin_indent.models.effect_surface.recompute_shipped` (the models import this
        package, so it is passed in, not imported here).
    """
    checks = []
    for label, settings, depth, nu, f in sample_runs(sample or 1, directory):
        checks.append(Check(label, nu, relative_difference(f, forces_of(settings, depth, nu))))
    return Report(tuple(checks), source_digest())


def _write_index(directory: Path, index: dict) -> None:
    text = json.dumps(index, indent=1, sort_keys=True) + "\n"
    atomic_write(directory / INDEX, lambda fh: fh.write(text.encode()))


def stamp(directory: Path | None = None) -> str:
    """Add the installed source digest to the digests the shipped surfaces are accepted for.

    Call only after :func:`verify` passed (``build_shipped_surfaces.py verify --stamp``).
    """
    d = Path(SHIPPED_DIR if directory is None else directory)
    index = json.loads((d / INDEX).read_text(encoding="utf-8"))
    code = source_digest()
    index["verified_code"] = sorted(set(index.get("verified_code", [])) | {code})
    _write_index(d, index)
    _shipped.cache_clear()
    return code


# ------------------------------------------------------------------ export
def _label(settings: Mapping, depth_mm: np.ndarray) -> str:
    params = ", ".join(f"{k} {float(v):.4g}" for k, v in settings.get("unit_parameters", []))
    return (f"{settings.get('model')} R = {float(settings['radius_mm']):g} mm, mesh {settings.get('mesh')}, "
            f"depths to {float(depth_mm[-1]):g} mm" + (f" ({params})" if params else ""))


def _order(run) -> tuple:
    """Runs of a family in order of their unit parameters (numbers; names sorted), e.g. (ratio, thickness),
    then of their deepest depth."""
    return (*(float(v) for _, v in run[0].get("unit_parameters", [])), float(run[1][-1]))


def export_cache(cache_dir: Path, directory: Path = SHIPPED_DIR, *, keep: bool = False) -> dict:
    """Write every complete surface run set of the run cache ``cache_dir`` as shipped surfaces.

    The runs' forward-model digest (their ``code_version``) is recorded as ``made_with`` and
    as the verified digest: the runs were made by that code. With ``keep``, the families
    (files) already shipped that the cache does not make again stay, if that digest is one
    they are verified for (else a ValueError: rebuild them all).
    """
    from skin_indent import __version__

    from ._store import RunStore

    families: dict[str, list] = {}
    codes = set()
    for info in sorted(Path(cache_dir, "runs").glob("*/settings.json")):
        meta = json.loads(info.read_text(encoding="utf-8"))
        settings, depth = meta["settings"], np.array(meta["depth_mm"], dtype=float)
        store = RunStore(info.parent, meta["key"], settings, depth)
        done = sorted(float(e["nu"]) for e in store.runs.values() if e.get("status") == "done")
        forces = [store.load(nu) for nu in done]
        if not done or any(f is None for f in forces) or store.failed():
            continue
        codes.add(expected_code_of(settings))
        bare = {k: v for k, v in settings.items() if k != "code_version"}
        family = f"{bare['model']}_R{float(bare['radius_mm']):g}mm_{bare['mesh']}"
        families.setdefault(family, []).append((bare, depth, np.array(done), np.array(forces)))
    if len(codes) != 1:
        raise ValueError(f"the runs of {cache_dir} were made by {len(codes)} forward-model sources: "
                         "export the runs of one build")
    code = codes.pop()
    made = {family.replace("+", "-").replace(" ", "-") + ".npz" for family in families}
    kept_surfaces, kept_files = [], {}
    if keep:
        old_index = _Shipped(directory).index
        kept_files = {n: h for n, h in old_index.get("files", {}).items() if n not in made}
        if kept_files and code not in old_index.get("verified_code", []):
            raise ValueError(f"the shipped surfaces are not verified for src.{code}, which made the runs of "
                             f"{cache_dir}: rebuild them all, or verify and stamp them first")
        kept_surfaces = [e for e in old_index["surfaces"] if e["file"] in kept_files]
    directory.mkdir(parents=True, exist_ok=True)
    for old in directory.glob("*.npz"):
        if old.name not in kept_files:
            old.unlink()
    surfaces, files = list(kept_surfaces), dict(kept_files)
    for family, runs in sorted(families.items()):
        name = family.replace("+", "-").replace(" ", "-") + ".npz"
        arrays = {}
        for i, (bare, depth, nus, f) in enumerate(sorted(runs, key=_order)):
            arrays.update({f"s{i}_depth_mm": depth, f"s{i}_nu": nus, f"s{i}_f": f})
            surfaces.append({"key": physics_key(bare, depth), "settings": bare, "file": name, "array": f"s{i}",
                             "nu": nus.tolist(), "label": _label(bare, depth)})
        data = npz_bytes(**arrays)
        atomic_write(directory / name, lambda fh, data=data: fh.write(data))
        files[name] = hashlib.sha256(data).hexdigest()
    index = {"format": _FORMAT, "version": _VERSION, "files": files, "surfaces": surfaces, "verified_code": [code],
             "made_with": {"package": __version__, "code": code,
                           "date": _dt.datetime.now(_dt.timezone.utc).date().isoformat()}}
    _write_index(directory, index)
    _shipped.cache_clear()
    return index
