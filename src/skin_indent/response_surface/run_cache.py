"""The run cache of single finite-element runs: everything a diagnosis solves beyond its surfaces.

A response surface keeps its runs in a :class:`~skin_indent.response_surface.RunStore`
(one directory per surface). The other runs of a fit or a diagnosis (the finite-element
model in the loop, :class:`~skin_indent.models.fe_core.FECore`, its screening runs, the
identifiability checks, the forward runs of a suggested measurement) are single runs, each
kept here as one file, so that the same command run again solves nothing.

A run is named by the SHA-256 of its *key parts* (JSON: everything that determines its
result, e.g. the sample as built, the sphere radius, the depths solved, the mesh and the
Newton tolerance) and of the digest of the forward-model sources (:func:`source_digest`),
so that a change of the mechanics invalidates every entry. Layout of
``cache_dir/fe-runs/``::

    <key[:2]>/<key>.npz          one finished run (its arrays), or a run that failed
    <key[:2]>/.<key>.lock        held by the process computing that run

Each file holds the arrays of the run, its full key and a SHA-256 of the arrays; it is
written atomically (:func:`~skin_indent.runtime.atomic.atomic_write`), so a reader never
sees half a file. An entry that cannot be read, holds another key or fails its checksum
is damaged: it is recomputed and replaced, never trusted. Several processes may share a
cache: a run is computed under its lock (:func:`file_lock`, the ``filelock`` library),
and a process that finds the lock taken waits for the other one's result instead of
solving the same run twice.

A run that failed for a reason the same inputs would give again (the solver did not
converge, :data:`DETERMINISTIC_FAILURES`) is kept as a failure with its message, so that a
rerun does not try it again; any other error (a worker that died, memory) is not kept.

Examples
--------
>>> import tempfile, numpy as np
>>> cache = RunCache(tempfile.mkdtemp())
>>> cache.get_or_compute({"what": "a doubled vector", "x": [1, 2]}, lambda: {"y": np.array([2.0, 4.0])})["y"]
array([2., 4.])
>>> cache.get_or_compute({"what": "a doubled vector", "x": [1, 2]}, lambda: 1 / 0)["y"]  # from the file
array([2., 4.])
>>> cache.counts["computed"], cache.counts["hits"]
(1, 1)
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import io
import threading
from pathlib import Path
from typing import Callable, Hashable, Mapping

import numpy as np
from filelock import FileLock, Timeout

from ..runtime.atomic import atomic_write
from ._cache import canonical_json, default_cache_dir, source_digest
from ._store import npz_bytes

#: the folder of the run cache inside a cache directory
FOLDER = "fe-runs"
#: names of the exception types whose failures are kept (the same inputs fail the same way)
DETERMINISTIC_FAILURES = ("ConvergenceError",)
_FORMAT = "skin_indent.fe_run/1"
_ERROR = "__error__"


class RunFailed(RuntimeError):
    """A run that failed, as the run cache keeps it: the message of the original error."""


def _digest(arrays: Mapping[str, np.ndarray]) -> str:
    """SHA-256 of named arrays (names, dtypes, shapes and bytes, in name order)."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.tobytes())
    return h.hexdigest()


@functools.lru_cache(maxsize=None)
def _file_digest(path: str) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:12]


def module_digest(*modules) -> str:
    """Digest (12 hex digits) of the source files of ``modules`` (module objects), read once per process.

    Key parts of runs whose result depends on code outside the forward model's sources
    (:func:`source_digest`) name it with this, e.g. the module that decides which depths a run solves.
    """
    return hashlib.sha256("".join(_file_digest(m.__file__) for m in modules).encode()).hexdigest()[:12]


class RunCache:
    """Finished single finite-element runs on disk, one file per run (see the module docstring).

    Parameters
    ----------
    cache_dir : path, optional
        The cache directory (default :func:`default_cache_dir`: ``$SKIN_INDENT_CACHE`` or
        ``~/.cache/skin_indent``); runs are kept in its ``fe-runs`` folder.

    Attributes
    ----------
    dir : Path
        The folder of the runs.
    counts : dict
        ``hits`` (runs read from the cache), ``computed`` (runs computed here and kept),
        ``failed`` (computed here and failed), ``damaged`` (entries found damaged and
        recomputed), ``waited`` (runs another process was computing, waited for).
    """

    def __init__(self, cache_dir=None):
        self.dir = Path(default_cache_dir() if cache_dir is None else cache_dir) / FOLDER
        self.counts = {"hits": 0, "computed": 0, "failed": 0, "damaged": 0, "waited": 0}
        self._count_lock = threading.Lock()
        self._code = None

    def __repr__(self):
        return f"RunCache({str(self.dir)!r})"

    def _count(self, what: str, n: int = 1) -> None:
        with self._count_lock:
            self.counts[what] += n

    # ------------------------------------------------------------------ keys and files
    def key(self, parts: Mapping) -> str:
        """The SHA-256 (hex) of the canonical JSON of ``parts`` and the forward-model source digest
        (:func:`source_digest`, read once per cache object)."""
        if self._code is None:
            self._code = source_digest()
        payload = {"format": _FORMAT, "code": self._code, "parts": parts}
        return hashlib.sha256(canonical_json(payload).encode()).hexdigest()

    def path(self, key: str) -> Path:
        """The file of the run ``key``."""
        return self.dir / key[:2] / f"{key}.npz"

    def load(self, key: str) -> dict | None:
        """The arrays of the run ``key``, or None if it is not in the cache or its entry is damaged.

        Raises
        ------
        RunFailed
            The run is kept as a failure (its message).
        """
        path = self.path(key)
        try:
            raw = path.read_bytes()
        except FileNotFoundError:
            return None
        except OSError:
            self._count("damaged")
            return None
        try:
            with np.load(io.BytesIO(raw), allow_pickle=False) as z:
                arrays = {name: z[name] for name in z.files}
            stored_key = str(arrays.pop("__key__"))
            checksum = str(arrays.pop("__sha256__"))
            ok = stored_key == key and checksum == _digest(arrays)
        except Exception:  # noqa: BLE001 - any damage (truncated, not a zip, missing members): not trusted
            ok = False
        if not ok:
            self._count("damaged")
            return None
        if _ERROR in arrays:
            raise RunFailed(str(arrays[_ERROR]))
        return arrays

    def store(self, key: str, arrays: Mapping[str, np.ndarray]) -> Path:
        """Keep the arrays of the run ``key`` (written atomically; names must not start with ``__``)."""
        arrays = {str(k): np.asarray(v) for k, v in arrays.items()}
        if any(k.startswith("__") for k in arrays):
            raise ValueError("array names starting with '__' are the cache's own")
        return self._write(key, arrays)

    def store_failure(self, key: str, message: str) -> Path:
        """Keep the run ``key`` as a failure with its message (:meth:`load` raises :class:`RunFailed`)."""
        return self._write(key, {_ERROR: np.array(str(message).strip() or "failed")})

    def _write(self, key: str, arrays: dict) -> Path:
        data = npz_bytes(**arrays, __key__=np.array(key), __sha256__=np.array(_digest(arrays)))
        return atomic_write(self.path(key), lambda fh: fh.write(data))

    def _lock(self, key: str) -> FileLock:
        path = self.path(key)
        path.parent.mkdir(parents=True, exist_ok=True)
        # not thread-local: taken where runs are handed out, released where their results come in
        return FileLock(str(path.with_name(f".{key}.lock")), mode=0o644, thread_local=False)

    # ------------------------------------------------------------------ get or compute
    def get_or_compute(self, parts: Mapping, compute: Callable[[], Mapping[str, np.ndarray]]) -> dict:
        """The arrays of the run described by ``parts``: from the cache, else ``compute()`` (then kept).

        Raises
        ------
        RunFailed
            The run is kept as a failure.
        Exception
            What ``compute`` raised (kept as a failure when deterministic).
        """
        def compute_many(tags):
            for tag in tags:
                try:
                    value = compute()
                except Exception as err:  # noqa: BLE001 - kept as a failure when deterministic, then raised
                    yield tag, None, err
                else:
                    yield tag, value, None

        value = self.get_or_compute_many({0: parts}, compute_many)[0]
        if isinstance(value, BaseException):
            raise value
        return value

    def get_or_compute_many(self, items: Mapping[Hashable, Mapping], compute_many) -> dict:
        """Several runs at once: ``{tag: arrays or exception}`` for ``items`` ``{tag: key parts}``.

        Runs found in the cache are read; the others are computed by ``compute_many(tags)``,
        which yields ``(tag, arrays or None, exception or None)`` in any order (e.g. from
        :meth:`~skin_indent.runtime.executors.Executor.imap_unordered`), each kept as it
        comes. A run another process is computing is waited for, then read (or computed
        here if that process did not keep it).

        Returns
        -------
        dict
            ``{tag: dict of arrays}``, or the exception of a run that failed (a
            :class:`RunFailed` for a failure read from the cache).
        """
        keys = {tag: self.key(parts) for tag, parts in items.items()}
        out: dict = {}
        todo = [tag for tag in keys if not self._found(tag, keys[tag], out)]
        busy, claims = [], {}
        for tag in todo:
            lock = self._lock(keys[tag])
            try:
                lock.acquire(timeout=0)
            except Timeout:  # another process computes it: wait for it after ours
                busy.append(tag)
                continue
            if self._found(tag, keys[tag], out):  # finished by another process meanwhile
                lock.release()
                continue
            claims[tag] = lock
        try:
            self._compute(list(claims), keys, compute_many, out, claims)
            for tag in busy:
                with self._lock(keys[tag]):
                    self._count("waited")
                    if not self._found(tag, keys[tag], out):
                        self._compute([tag], keys, compute_many, out, {})
        finally:
            for lock in claims.values():
                with contextlib.suppress(Exception):
                    lock.release()
        return {tag: out[tag] for tag in items}

    def _found(self, tag, key: str, out: dict) -> bool:
        try:
            arrays = self.load(key)
        except RunFailed as err:
            out[tag] = err
            self._count("hits")
            return True
        if arrays is None:
            return False
        out[tag] = arrays
        self._count("hits")
        return True

    def _compute(self, tags: list, keys: dict, compute_many, out: dict, claims: dict) -> None:
        if not tags:
            return
        for tag, value, error in compute_many(tags):
            if tag not in keys:
                raise RuntimeError(f"compute_many yielded a run that was not asked for: {tag!r}")
            try:
                if error is not None:
                    out[tag] = error
                    self._count("failed")
                    if type(error).__name__ in DETERMINISTIC_FAILURES:
                        with contextlib.suppress(OSError):  # a read-only cache: the run still failed
                            self.store_failure(keys[tag], str(error))
                else:
                    out[tag] = {k: np.asarray(v) for k, v in value.items()}
                    self._count("computed")
                    with contextlib.suppress(OSError):  # a read-only cache: the run still stands
                        self.store(keys[tag], out[tag])
            finally:
                lock = claims.pop(tag, None)
                if lock is not None:
                    lock.release()
        lost = [tag for tag in tags if tag not in out]
        if lost:
            raise RuntimeError(f"compute_many did not yield {len(lost)} of the runs asked for (e.g. {lost[0]!r})")
