"""The run cache: one directory of finished forward runs per (settings, depths), with a manifest.

Layout of ``cache_dir/runs/<key[:24]>/``::

    settings.json                      the settings and depths (for humans)
    manifest.json                      what is finished, written atomically
    .lock                              file lock around every manifest update
    .nu_<nu>.lock                      held by the builder computing that run
    nu_<nu>_<sha256[:16]>.npz          one finished run, content-addressed

The manifest (JSON) lists each run by nu: ``status`` ``"done"`` with the run file's
name, size and SHA-256 (and when, where and how long it ran), or ``"failed"`` with
the reason and the number of attempts. A run file is trusted only if the manifest
lists it as done and the file's bytes have the listed checksum (and it holds the
expected key, nu and depths); anything else is recomputed. Since files are renamed
into place only once complete (and fsynced), and listed only after that, a build
that is killed at any instant leaves a cache whose listed runs are all complete.

Several processes may build into the same directory at once: each update of the
manifest re-reads it under an exclusive lock of ``.lock`` (:func:`file_lock`, the
``filelock`` library: ``flock`` on POSIX) and merges one entry (a finished run is never
replaced by a failure). A builder computes a run only while it holds that run's lock
(:meth:`RunStore.claim`) and after checking, under it, that the run is not done: two
builders of one surface share the runs, each computed once. Run files are named by
their content, and written deterministically, so two processes that compute the same
run write the same file. The kernel drops the locks of a killed process.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import io
import json
import os
import socket
import warnings
import zipfile
from pathlib import Path

import numpy as np
from filelock import FileLock, Timeout

from ..runtime.atomic import atomic_write
from ._cache import canonical_json

MANIFEST = "manifest.json"
LOCK = ".lock"
_FORMAT = "skin_indent.run_manifest"
_VERSION = 1
#: temporary files older than this (s) are left-overs of killed writers, removed
STALE_TMP_S = 3600.0


def _lock(path) -> FileLock:
    # not thread-local: a claim taken while tasks are handed out is released where results come in
    return FileLock(os.fspath(path), mode=0o644, thread_local=False)


@contextlib.contextmanager
def file_lock(path: Path):
    """Exclusive advisory lock on ``path`` (created if needed, 0644) for the ``with`` block.

    Blocks until the lock is free; a separate lock per call, so two threads of one
    process exclude each other as two processes do. The kernel releases the lock of a
    killed process.
    """
    with _lock(path):
        yield


def npz_bytes(**arrays) -> bytes:
    """An uncompressed ``.npz`` (readable by :func:`numpy.load`) with fixed timestamps.

    :func:`numpy.savez` stamps the current time into the zip, so equal data gives
    different bytes; this does not, so files can be named by their checksum.
    """
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED, allowZip64=True) as zf:
        for name, value in arrays.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.external_attr = 0o644 << 16
            with zf.open(info, "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, np.asanyarray(value), allow_pickle=False)
    return buf.getvalue()


def nu_tag(nu: float) -> str:
    """The manifest key of a run: the shortest repr of ``float(nu)`` (round-trips exactly)."""
    return repr(float(nu))


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


class RunStore:
    """Finished forward runs of one ``(settings, depths)`` key, in ``run_dir``.

    Parameters
    ----------
    run_dir : path
        The directory (created).
    key : str
        Full SHA-256 run key (settings + depths); checked in every file.
    settings : mapping
        The settings (written to ``settings.json`` for humans).
    depth_mm : numpy.ndarray
        The depths of every run (mm).
    """

    def __init__(self, run_dir, key: str, settings, depth_mm: np.ndarray):
        self.dir = Path(run_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.key = key
        self.depth_mm = np.array(depth_mm, dtype=float)
        self.manifest_path = self.dir / MANIFEST
        self.lock_path = self.dir / LOCK
        self.settings = settings
        self._shipped_key = None  # the key of the shipped runs (shipped.physics_key), computed when first needed
        self._runs: dict = {}
        self._signature = None  # (mtime_ns, size, inode) of the manifest last read
        info = self.dir / "settings.json"
        if not info.exists():
            atomic_write(info, lambda fh: fh.write(json.dumps(
                {"key": key, "settings": settings, "depth_mm": self.depth_mm.tolist()}, indent=1).encode()))
        self._remove_stale_tmp()
        self.refresh()

    def _remove_stale_tmp(self):
        """Delete temporary files that a killed writer left (never read: only renamed when complete)."""
        import time

        old = time.time() - STALE_TMP_S
        for p in self.dir.glob(".*.tmp"):
            with contextlib.suppress(OSError):
                if p.stat().st_mtime < old:
                    p.unlink()

    # ------------------------------------------------------------------ manifest
    def _stat(self):
        try:
            st = self.manifest_path.stat()
        except FileNotFoundError:
            return None
        return (st.st_mtime_ns, st.st_size, st.st_ino)

    def _read_manifest(self, set_aside: bool = False) -> dict:
        """The runs of the manifest on disk (empty if none or unreadable).

        An unreadable manifest was not written by us (writes are atomic): with
        ``set_aside`` (only under the lock) it is renamed for inspection.
        """
        try:
            raw = self.manifest_path.read_bytes()
        except FileNotFoundError:
            return {}
        try:
            data = json.loads(raw.decode("utf-8"))
            ok = (data.get("format") == _FORMAT and data.get("version") == _VERSION and data.get("key") == self.key
                  and isinstance(data.get("runs"), dict))
        except (UnicodeDecodeError, json.JSONDecodeError, AttributeError):
            ok = False
        if not ok:
            where = ""
            if set_aside:
                aside = self.manifest_path.with_name(f"{MANIFEST}.unreadable-{os.getpid()}")
                with contextlib.suppress(OSError):
                    os.replace(self.manifest_path, aside)
                    where = f"; moved to {aside.name}"
            warnings.warn(f"run cache manifest {self.manifest_path} is unreadable{where}: its runs will be "
                          "recomputed", RuntimeWarning, stacklevel=4)
            return {}
        return data["runs"]

    def refresh(self) -> bool:
        """Re-read the manifest if it changed on disk; True if it did."""
        sig = self._stat()
        if sig == self._signature and sig is not None:
            return False
        self._runs = self._read_manifest()  # if replaced meanwhile, the next refresh reads it again
        self._signature = sig
        return True

    @property
    def runs(self) -> dict:
        """``{nu_tag: entry}`` as last read (a copy)."""
        return {k: dict(v) for k, v in self._runs.items()}

    def entry(self, nu: float) -> dict | None:
        """The manifest entry of ``nu`` as last read, or None."""
        return self._runs.get(nu_tag(nu))

    def is_done(self, nu: float) -> bool:
        """Listed as done in the manifest (as last read); the file is checked by :meth:`load`."""
        e = self._runs.get(nu_tag(nu))
        return e is not None and e.get("status") == "done"

    def _write_manifest(self, runs: dict) -> None:
        # one run per line, in order of nu: readable, and diff-friendly
        body = ",\n".join(f"  {json.dumps(k)}: {canonical_json(runs[k])}" for k in sorted(runs, key=float))
        text = (f'{{"format": "{_FORMAT}", "version": {_VERSION}, "key": "{self.key}", "runs": {{\n'
                f"{body}\n}}}}\n")
        atomic_write(self.manifest_path, lambda fh: fh.write(text.encode()))

    @contextlib.contextmanager
    def _update(self):
        """Lock, re-read the manifest, let the caller edit the runs, write it back."""
        with file_lock(self.lock_path):
            runs = self._read_manifest(set_aside=True)
            before = canonical_json(runs)
            yield runs
            if canonical_json(runs) != before:
                self._write_manifest(runs)
            self._runs = runs
            self._signature = self._stat()

    # ------------------------------------------------------------------ run files
    def _check_file(self, entry: dict) -> np.ndarray | None:
        """The forces of a done entry if its file is intact, else None."""
        name = entry.get("file")
        if not isinstance(name, str) or "/" in name or "\\" in name:
            return None
        try:
            raw = (self.dir / name).read_bytes()
        except OSError:
            return None
        if hashlib.sha256(raw).hexdigest() != entry.get("sha256"):
            return None
        try:
            with np.load(io.BytesIO(raw), allow_pickle=False) as z:
                ok = (str(z["key"]) == self.key and float(z["nu"]) == float(entry["nu"])
                      and np.array_equal(z["depth_mm"], self.depth_mm))
                f = np.array(z["unit_force_mN"], dtype=float)
        except Exception:  # noqa: BLE001 - any damage: not trusted
            return None
        return f if ok and f.shape == self.depth_mm.shape and np.all(np.isfinite(f)) else None

    def load(self, nu: float) -> np.ndarray | None:
        """The unit forces of a finished run of ``nu``, or None (not listed, or damaged, and not shipped).

        A run the manifest does not list as done is looked up among the surfaces shipped with
        the package (:func:`skin_indent.response_surface.shipped.lookup`: the same settings but
        ``code_version``, depths and nu, verified for this ``code_version``); it is returned as
        a cached run would be, and not written to the cache.
        """
        e = self._runs.get(nu_tag(nu))
        if e is None or e.get("status") != "done":
            return self._load_shipped(nu)
        return self._check_file(e)

    def _load_shipped(self, nu: float) -> np.ndarray | None:
        from . import shipped  # lazy: shipped imports this module

        if not isinstance(self.settings, dict):
            return None
        if self._shipped_key is None:
            self._shipped_key = shipped.physics_key(self.settings, self.depth_mm)
        return shipped.lookup(self.settings, self.depth_mm, nu, key=self._shipped_key)

    def record_done(self, nu: float, values: np.ndarray, *, seconds: float | None = None,
                    cpu_seconds: float | None = None, worker: str | None = None) -> Path:
        """Write the run file (atomically, content-addressed), then list it in the manifest."""
        nu = float(nu)
        values = np.asarray(values, dtype=float)
        data = npz_bytes(unit_force_mN=values, depth_mm=self.depth_mm, nu=np.float64(nu), key=np.array(self.key))
        sha = hashlib.sha256(data).hexdigest()
        name = f"nu_{nu_tag(nu)}_{sha[:16]}.npz"
        path = self.dir / name
        atomic_write(path, lambda fh: fh.write(data))
        entry = {"nu": nu, "status": "done", "file": name, "bytes": len(data), "sha256": sha, "finished": _now(),
                 "seconds": None if seconds is None else round(float(seconds), 4),
                 "cpu_seconds": None if cpu_seconds is None else round(float(cpu_seconds), 4),
                 "worker": worker, "by": f"{socket.gethostname()}:{os.getpid()}"}
        with self._update() as runs:
            old = runs.get(nu_tag(nu))
            if old and old.get("status") == "done" and old.get("file") != name and self._check_file(old) is not None:
                # another process finished it first (with other bytes): keep theirs
                path.unlink(missing_ok=True)
                return self.dir / old["file"]
            runs[nu_tag(nu)] = entry
        return path

    def record_failed(self, nu: float, reason: str, *, worker: str | None = None) -> None:
        """List a failed run (retried by the next build) unless it is already done."""
        nu = float(nu)
        with self._update() as runs:
            old = runs.get(nu_tag(nu))
            if old and old.get("status") == "done" and self._check_file(old) is not None:
                return
            attempts = int(old.get("attempts", 0)) if old and old.get("status") == "failed" else 0
            runs[nu_tag(nu)] = {"nu": nu, "status": "failed", "reason": " ".join(str(reason).split()),
                                "attempts": attempts + 1, "finished": _now(), "worker": worker,
                                "by": f"{socket.gethostname()}:{os.getpid()}"}

    def claim(self, nu: float, *, wait: bool = False) -> FileLock | None:
        """The lock of run ``nu``, acquired (release it when the run is recorded), or None if another
        builder holds it (with ``wait``: block until it is free, then take it)."""
        lock = _lock(self.dir / f".nu_{nu_tag(nu)}.lock")
        try:
            lock.acquire(timeout=-1 if wait else 0)
        except Timeout:
            return None
        return lock

    def failed(self) -> dict[float, str]:
        """``{nu: reason}`` of the runs listed as failed (as last read)."""
        return {float(e["nu"]): e.get("reason", "?") for e in self._runs.values() if e.get("status") == "failed"}
