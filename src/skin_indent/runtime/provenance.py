"""How an output was made: the record every result file of the package carries.

:func:`provenance` collects the package and library versions, the command line, the
time (UTC), every input file with its sha256 and size, the settings of the fit (radius,
window, method, mesh, fixed parameters, ...) and the identity of the response surface(s)
used (their ``hash`` and ``settings``). It is a plain JSON-safe dict, embedded

- in a JSON output as an object (:func:`with_provenance`);
- in a CSV or TSV output as a block of ``#`` comment lines before the header
  (:func:`provenance_comment_lines`), which :func:`skin_indent.measurement.load_csv`
  skips and :func:`read_provenance` reads back.
"""

from __future__ import annotations

import datetime
import hashlib
import json
import os
import platform
import sys
from collections.abc import Iterable, Mapping
from importlib import metadata
from pathlib import Path

from .json_io import jsonable
from .. import __version__

__all__ = ["file_identity", "provenance", "provenance_comment_lines", "read_provenance", "surface_identity",
           "with_provenance"]

#: first word of every provenance comment line
COMMENT_KEY = "provenance"
#: distributions whose versions are recorded (import name: distribution name)
_LIBRARIES = {"numpy": "numpy", "scipy": "scipy", "scikit-fem": "scikit-fem"}
_CHUNK = 1 << 20


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
    """The identity of a response surface: its ``hash`` and ``settings``.

    Parameters
    ----------
    surface : ResponseSurface, dict, sequence of those, or None
        A surface (any object with ``hash`` and ``settings`` attributes), an identity
        already made (a dict, kept as is), or several of them (a list, duplicates by
        hash dropped).

    Returns
    -------
    dict, list of dict or None
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
    return jsonable({"hash": getattr(surface, "hash", None), "settings": getattr(surface, "settings", None),
                     "type": type(surface).__name__})


def provenance(command=None, inputs: Iterable = (), settings: Mapping | None = None, surface=None) -> dict:
    """The record of how an output was made (see the module docstring).

    Parameters
    ----------
    command : str or sequence of str, optional
        The command line; default ``sys.argv`` of this process.
    inputs : iterable of path
        Input files; each is recorded with its absolute path, sha256 and size in bytes
        (:func:`file_identity`), in the order given, each once.
    settings : mapping, optional
        The settings of the computation, e.g. ``{"radius_mm": 0.02, "window_mm":
        [0, 0.005], "method": "lsq", "mesh": "medium", "fixed": {"nu": 0.499}}``
        (made JSON-safe).
    surface : ResponseSurface, dict or sequence of those, optional
        The response surface(s) used (:func:`surface_identity`).

    Returns
    -------
    dict
        JSON-safe: ``skin_indent`` (version), ``python``, ``platform``, ``libraries``
        (numpy, scipy, scikit-fem versions), ``command`` (list of str),
        ``time_utc`` (ISO 8601), ``inputs`` (list of dict), ``settings``, ``surface``.

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
        key = os.path.abspath(os.fspath(path))
        if key not in seen:
            seen.add(key)
            files.append(file_identity(path))
    return jsonable({
        "skin_indent": __version__,
        "python": platform.python_version(),
        "platform": platform.platform(terse=True),
        "libraries": {name: _version(dist) for name, dist in _LIBRARIES.items()},
        "command": command,
        "time_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "inputs": files,
        "settings": dict(settings or {}),
        "surface": surface_identity(surface),
    })


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


def read_provenance(path_or_lines) -> dict:
    """The provenance record of a CSV or TSV file written with :func:`provenance_comment_lines`.

    Parameters
    ----------
    path_or_lines : path or iterable of str
        The file, or its lines.

    Returns
    -------
    dict
        As :func:`provenance` made it (``inputs`` a list); empty if the file has none.
    """
    if isinstance(path_or_lines, (str, os.PathLike)):
        with open(path_or_lines, encoding="utf-8") as fh:
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
