"""How an output was made: the record every result file of the package carries.

:func:`provenance` collects the package and library versions, the command line, the
time (UTC), every input file with its sha256 and size, the settings of the fit (radius,
window, method, mesh, fixed parameters, ...) and the identity of the response surface(s)
used (their ``hash`` and ``settings``). It is a plain JSON-safe dict, embedded

- in a JSON output as an object (:func:`with_provenance`);
- in a CSV or TSV output as a block of ``#`` comment lines before the header
  (:func:`provenance_comment_lines`), which :func:`skin_indent.measurement.load_csv`
  skips and :func:`read_provenance` reads back;
- in a PNG figure as text chunks (:func:`png_metadata`, through
  :func:`skin_indent.report.save_figure`), which :func:`read_provenance` reads back too.

A result of the Python API (:func:`skin_indent.fit`, :func:`skin_indent.diagnose`) records
its call (:func:`records_call`): ``api`` names the function, ``settings`` holds the
arguments given, ``inputs`` the curve's data digest (:func:`data_identity`).
"""

from __future__ import annotations

import contextvars
import dataclasses
import datetime
import functools
import hashlib
import inspect
import json
import os
import platform
import sys
from collections.abc import Iterable, Mapping
from importlib import metadata
from pathlib import Path

import numpy as np

from .json_io import jsonable
from .. import __version__

__all__ = ["PNG_KEY", "data_identity", "file_identity", "png_metadata", "provenance", "provenance_comment_lines",
           "read_provenance", "records_call", "surface_identity", "with_provenance"]

#: first word of every provenance comment line
COMMENT_KEY = "provenance"
#: distributions whose versions are recorded (import name: distribution name)
_LIBRARIES = {"numpy": "numpy", "scipy": "scipy", "scikit-fem": "scikit-fem"}
_CHUNK = 1 << 20
#: the PNG text key that holds the whole record as JSON (:func:`png_metadata`)
PNG_KEY = "skin_indent provenance"


def _version(distribution: str) -> str | None:
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return None


def file_identity(path) -> dict:
    """Path (absolute), sha256 and size of one input file.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    dict
        ``{"path", "sha256", "bytes"}``; for a path that cannot be read (missing, a
        directory, no permission) ``{"path", "error"}`` with a one-line reason instead:
        a provenance record never fails because an input is bad.
    """
    p = Path(os.fspath(path))
    where = str(p.resolve()) if p.exists() else str(p.absolute())
    try:
        st = p.stat()
    except OSError:
        st = None
    if st is not None and p.is_file() and os.access(p, os.R_OK):  # each file hashed once while it does not change
        return dict(_hashed(where, st.st_size, st.st_mtime_ns))
    return _hash_file(p, where)


@functools.lru_cache(maxsize=256)
def _hashed(where: str, size: int, mtime_ns: int) -> tuple:
    return tuple(_hash_file(Path(where), where).items())


def _hash_file(p: Path, where: str) -> dict:
    digest = hashlib.sha256()
    size = 0
    try:
        with open(p, "rb") as fh:
            for chunk in iter(lambda: fh.read(_CHUNK), b""):
                digest.update(chunk)
                size += len(chunk)
    except OSError as err:
        return {"path": where, "error": " ".join((err.strerror or str(err)).split()) or type(err).__name__}
    return {"path": where, "sha256": digest.hexdigest(), "bytes": size}


def surface_identity(surface) -> dict | list | None:
    """The identity of a response surface, or of any elastic force model a fit used.

    Parameters
    ----------
    surface : object, dict, sequence of those, or None
        A response surface (an object with ``hash`` and ``settings`` attributes); an effect
        surface (``effects``, ``axes`` and ``surfaces``, an array of response surfaces: one per
        node of the effect axes); the finite-element model in the loop (``effects``,
        ``mesh_name``, ``radius_mm``, ``depth_range``: its runs are made during the fit); an
        identity already made (a dict, kept as is); or several of them (a list, duplicates
        dropped).

    Returns
    -------
    dict, list of dict or None
        ``{"type", "hash", "settings"}`` for a response surface; for an effect surface
        ``hash`` is the sha256 of its sub-surfaces' hashes in node order, ``settings`` what
        they share (model, mesh, radius, code version), ``axes`` the nodes of each effect
        axis and ``surfaces`` how many sub-surfaces; the finite-element model in the loop has
        no ``hash`` (nothing is stored), its ``settings`` say what its runs solve (model,
        mesh, radius, deepest depth).
    """
    if surface is None:
        return None
    if isinstance(surface, Mapping):
        return jsonable(dict(surface))
    if isinstance(surface, (list, tuple, set)):
        out, seen = [], set()
        for s in surface:
            ident = surface_identity(s)
            key = json.dumps(ident, sort_keys=True)
            if ident is not None and key not in seen:
                seen.add(key)
                out.append(ident)
        return out
    kind = type(surface).__name__
    if getattr(surface, "surfaces", None) is not None and hasattr(surface, "axes"):  # an effect surface
        parts = list(np.asarray(surface.surfaces, dtype=object).flat)
        digest = hashlib.sha256()
        for part in parts:
            digest.update(str(getattr(part, "hash", "")).encode() + b"\0")
        settings = [dict(getattr(part, "settings", None) or {}) for part in parts]
        shared = {k: v for k, v in (settings[0] if settings else {}).items()
                  if k != "unit_parameters" and all(s.get(k) == v for s in settings)}
        return jsonable({"hash": digest.hexdigest(), "settings": shared, "type": kind,
                         "axes": {a.name: list(a.nodes) for a in surface.axes}, "surfaces": len(parts)})
    if hasattr(surface, "mesh_name") and hasattr(surface, "effects"):  # finite elements in the loop
        model = "neo-hooke" + "".join(f"+{getattr(e, 'name', e)}" for e in surface.effects)
        return jsonable({"hash": None, "type": kind,
                         "settings": {"model": model, "mesh": surface.mesh_name, "radius_mm": surface.radius_mm,
                                      "depth_range_mm": list(getattr(surface, "depth_range", ()))}})
    return jsonable({"hash": getattr(surface, "hash", None), "settings": getattr(surface, "settings", None),
                     "type": kind})


def data_identity(measurement) -> dict:
    """The identity of a curve held in memory: its source name and the sha256 of its data.

    Parameters
    ----------
    measurement : Measurement or PreparedCurve
        Anything with ``depth_mm`` and ``force_mN`` (and ``time_s``) arrays and a ``source``
        (a prepared curve: its measurement, as recorded).

    Returns
    -------
    dict
        ``{"source", "data_sha256", "points"}``: the sha256 of the float64 bytes of depth
        (mm), force (mN) and, when recorded, time (s), in that order; the same numbers give
        the same digest whatever file they came from.
    """
    m = getattr(measurement, "measurement", measurement)
    digest = hashlib.sha256()
    depth = None
    for name in ("depth_mm", "force_mN", "time_s"):
        values = getattr(m, name, None)
        if values is not None:
            arr = np.ascontiguousarray(values, dtype=np.float64)
            depth = arr if depth is None else depth
            digest.update(name.encode() + b"\0" + arr.tobytes())
    return {"source": str(getattr(m, "source", "array")), "data_sha256": digest.hexdigest(),
            "points": 0 if depth is None else int(depth.size)}


def provenance(command=None, inputs: Iterable = (), settings: Mapping | None = None, surface=None, *,
               api: str | None = None) -> dict:
    """The record of how an output was made (see the module docstring).

    Parameters
    ----------
    command : str or sequence of str, optional
        The command line; default ``sys.argv`` of this process.
    inputs : iterable of path or mapping
        Input files; each is recorded with its absolute path, sha256 and size in bytes
        (:func:`file_identity`; a file is hashed once while its size and modification
        time stay the same), in the order given, each once. A mapping (a curve held in
        memory, :func:`data_identity`) is recorded as it is.
    settings : mapping, optional
        The settings of the computation, e.g. ``{"radius_mm": 0.02, "window_mm":
        [0, 0.005], "method": "lsq", "mesh": "medium", "fixed": {"nu": 0.499}}``
        (made JSON-safe).
    surface : ResponseSurface, dict or sequence of those, optional
        The response surface(s) used (:func:`surface_identity`).
    api : str, optional
        The function of the Python API that made the output (``"skin_indent.fit"``);
        recorded as ``api`` (the key is absent for a command of the ``skin-indent`` CLI).

    Returns
    -------
    dict
        JSON-safe: ``skin_indent`` (version), ``python``, ``platform``, ``libraries``
        (numpy, scipy, scikit-fem versions), ``command`` (list of str), ``api`` (if
        given), ``time_utc`` (ISO 8601), ``inputs`` (list of dict: a file path, or a
        mapping such as :func:`data_identity` kept as is), ``settings``, ``surface``.

    Examples
    --------
    >>> prov = provenance(["skin-indent", "fit", "a.csv"], settings={"method": "lsq"})
    >>> prov["command"], prov["settings"]
    (['skin-indent', 'fit', 'a.csv'], {'method': 'lsq'})
    """
    if command is None:
        command = list(sys.argv)
    elif isinstance(command, (str, os.PathLike)):
        command = [os.fspath(command)]
    else:
        command = [os.fspath(c) if isinstance(c, os.PathLike) else str(c) for c in command]
    seen, files = set(), []
    for path in inputs:
        if isinstance(path, Mapping):
            key = json.dumps(jsonable(dict(path)), sort_keys=True)
        else:
            key = os.path.abspath(os.fspath(path))
        if key not in seen:
            seen.add(key)
            files.append(dict(path) if isinstance(path, Mapping) else file_identity(path))
    return jsonable({
        "skin_indent": __version__,
        "python": platform.python_version(),
        "platform": _PLATFORM,
        "libraries": _LIBRARY_VERSIONS,
        "command": command,
        **({"api": api} if api is not None else {}),
        "time_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "inputs": files,
        "settings": dict(settings or {}),
        "surface": surface_identity(surface),
    })


#: what does not change while a process runs, looked up once
_PLATFORM = platform.platform(terse=True)
_LIBRARY_VERSIONS = {name: _version(dist) for name, dist in _LIBRARIES.items()}


#: set while a recorded API call runs: the calls it makes are not recorded again
_RECORDING = contextvars.ContextVar("skin_indent_recording", default=False)


def records_call(api: str, data: str = "data", leave_out: tuple = ("context",)):
    """Decorate an API function whose result gets the provenance of its call.

    The result (a dataclass with a ``provenance`` field) is returned with ``provenance``
    set to :func:`provenance` of the call: ``api`` the function's public name, ``inputs``
    the :func:`data_identity` of the argument ``data``, ``settings`` the other arguments
    as given (not the defaults; made JSON-safe; a surface or context object is left out:
    the surfaces used are recorded by identity from the result's ``surface``, or its
    ``surfaces`` (a diagnosis: every surface its fits used)). Calls made
    inside a recorded call (the two fits of the incompressible limit) are not recorded.

    Parameters
    ----------
    api : str
        E.g. ``"skin_indent.fit"``.
    data : str
        Name of the argument holding the curve.
    leave_out : tuple of str
        Arguments not recorded (besides ``data`` and ``surface``): where the work runs,
        not what it computes.
    """
    def decorate(func):
        signature = inspect.signature(func)

        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            if _RECORDING.get():
                return func(*args, **kwargs)
            token = _RECORDING.set(True)
            try:
                result = func(*args, **kwargs)
            finally:
                _RECORDING.reset(token)
            try:
                bound = signature.bind(*args, **kwargs).arguments
            except TypeError:  # pragma: no cover - func accepted these arguments
                bound = dict(kwargs)
            settings = {}
            for name, value in bound.items():
                if name in (data, "surface", *leave_out):
                    continue
                kind = signature.parameters[name].kind
                if kind is inspect.Parameter.VAR_KEYWORD:
                    settings.update({k: v for k, v in value.items() if k not in leave_out})
                else:
                    settings[name] = value
            given = bound.get(data)
            several = isinstance(given, (list, tuple)) or hasattr(given, "curves")  # curves of one sample
            inputs = [] if data not in bound else ([data_identity(m) for m in given] if several
                                                   else [data_identity(given)])
            used = getattr(result, "surface", None) or getattr(result, "surfaces", None) or None
            record = provenance(inputs=inputs, settings=settings, surface=used, api=api)
            return dataclasses.replace(result, provenance=record)

        return wrapper

    return decorate


def with_provenance(obj: Mapping, prov: Mapping) -> dict:
    """A JSON object with the provenance record under the key ``"provenance"``.

    Parameters
    ----------
    obj : mapping
        The JSON output (e.g. :meth:`CurveFit.to_dict`).
    prov : mapping
        From :func:`provenance`.

    Returns
    -------
    dict
        JSON-safe (:func:`skin_indent.runtime.json_io.jsonable`).
    """
    return jsonable({**dict(obj), "provenance": dict(prov)})


def provenance_comment_lines(prov: Mapping) -> list[str]:
    """The provenance record as ``#`` comment lines for a CSV or TSV header.

    One line per item, ``# provenance <key>: <compact JSON>``, each input file on a line
    of its own (``# provenance input: {"path": ..., "sha256": ..., "bytes": ...}``),
    after a readable first line. No line holds a newline (JSON escapes them), and no
    line looks like a radius statement to :func:`skin_indent.measurement.load_csv`.

    Parameters
    ----------
    prov : mapping
        From :func:`provenance`.

    Returns
    -------
    list of str
        Lines without line endings; :func:`read_provenance` reads them back.

    Examples
    --------
    >>> lines = provenance_comment_lines(provenance(["skin-indent"], settings={"mesh": "coarse"}))
    >>> lines[0].startswith("# written by skin_indent")
    True
    """
    prov = jsonable(dict(prov))
    libs = ", ".join(f"{k} {v}" for k, v in (prov.get("libraries") or {}).items())
    lines = [f"# written by skin_indent {prov.get('skin_indent')} (Python {prov.get('python')}; {libs}) "
             f"at {prov.get('time_utc')}"]
    for key, value in prov.items():
        if key == "inputs":
            lines.extend(f"# {COMMENT_KEY} input: {json.dumps(v, sort_keys=True)}" for v in value)
        else:
            lines.append(f"# {COMMENT_KEY} {key}: {json.dumps(value, sort_keys=True)}")
    return lines


def png_metadata(prov: Mapping | None) -> dict:
    """PNG text chunks that carry a provenance record (``savefig(..., metadata=...)``).

    Parameters
    ----------
    prov : mapping or None
        From :func:`provenance`; None gives only ``Software``.

    Returns
    -------
    dict of str
        ``Software`` (``skin_indent VERSION``), ``Source`` (the command line, or the API
        call), ``Creation Time`` and :data:`PNG_KEY`, the whole record as JSON (ASCII),
        which :func:`read_provenance` reads back.
    """
    out = {"Software": f"skin_indent {__version__}"}
    if prov:
        prov = jsonable(dict(prov))
        out["Source"] = prov.get("api") or " ".join(map(str, prov.get("command") or ()))
        if prov.get("time_utc"):
            out["Creation Time"] = str(prov["time_utc"])
        out[PNG_KEY] = json.dumps(prov, sort_keys=True)
    return out


def record_in(obj) -> dict:
    """The provenance record a JSON output holds: itself, or under ``"provenance"``."""
    if isinstance(obj, Mapping) and isinstance(obj.get("provenance"), Mapping):
        return dict(obj["provenance"])
    if isinstance(obj, Mapping) and "settings" in obj and "skin_indent" in obj:
        return dict(obj)
    return {}


def read_provenance(path_or_lines) -> dict:
    """The provenance record of an output of the package.

    Parameters
    ----------
    path_or_lines : path or iterable of str
        A CSV or TSV file written with :func:`provenance_comment_lines` (or its lines), a
        PNG figure (:func:`png_metadata`), or a JSON output (the ``provenance`` object of
        ``fit --json``, ``diagnose --json``, ``demo.json``, or a record on its own).

    Returns
    -------
    dict
        As :func:`provenance` made it (``inputs`` a list); empty if the file has none.
    """
    if isinstance(path_or_lines, (str, os.PathLike)):
        with open(path_or_lines, "rb") as fh:
            head = fh.read(8)
        if head.startswith(b"\x89PNG"):
            from PIL import Image

            with Image.open(path_or_lines) as image:
                text = dict(getattr(image, "text", {}) or {})
            return json.loads(text[PNG_KEY]) if PNG_KEY in text else {}
        with open(path_or_lines, encoding="utf-8") as fh:
            if head.lstrip()[:1] in (b"{", b"["):
                try:
                    return record_in(json.load(fh))
                except json.JSONDecodeError:
                    return {}
            lines = [line for line in fh if line.startswith("#")]
    else:
        lines = list(path_or_lines)
    out: dict = {}
    prefix = f"# {COMMENT_KEY} "
    for line in lines:
        if not line.startswith(prefix):
            continue
        key, _, value = line[len(prefix):].rstrip("\r\n").partition(": ")
        if key == "input":
            out.setdefault("inputs", []).append(json.loads(value))
        else:
            out[key] = json.loads(value)
    if out:
        out.setdefault("inputs", [])
    return out
