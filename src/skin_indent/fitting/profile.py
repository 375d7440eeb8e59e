"""Fit profiles: the settings of a fit, saved to rerun it with the same numbers.

A profile is a JSON (or, with Python >= 3.11, TOML) object whose keys are the options of
``skin-indent fit`` without their dashes:

========== =========================================== ==============================
key        value                                       option
========== =========================================== ==============================
model      ``"neo-hooke+layer"``                       ``--model``
fix        ``{"nu": 0.45, "thickness_mm": 1.2}``       ``--fix NAME=VALUE``
prior      ``{"thickness_mm": [1.2, 0.1]}`` (mean, SD) ``--prior NAME=MEAN:SD``
free       ``["nu"]``                                  ``--free nu``
method     ``"lsq"``, ``"ekf"`` or ``"ekf-paper"``     ``--method``
window     ``[0.05, 0.6]`` (mm)                        ``--window MIN:MAX``
radius     sphere radius (mm)                          ``--radius``
mesh       ``"coarse"``, ``"medium"`` or ``"fine"``    ``--mesh``
noise      noise standard deviation (mN)               ``--noise``
contact    ``"auto"``, ``"fit"`` or ``"origin"``       ``--contact``
start      ``[E_kPa, nu]``                             ``--start E,nu``
tol        stop rule of the filters                    ``--tol``
index      curve of each file (from 0)                 ``--index``
surface    response surface file                       ``--surface``
========== =========================================== ==============================

The names the provenance records use are taken too (``fixed``, ``priors``, ``window_mm``,
``radius_mm``, ``noise_mN``, ``x0``; and the keyword names of :func:`skin_indent.fit`), so
the provenance of any fit output is a profile (:func:`read_profile`): the ``#`` header of
a fit CSV or batch TSV, the ``provenance`` object of ``fit --json``, a fit figure's PNG
metadata; its ``settings`` are used. ``skin-indent fit --save-profile FILE`` writes
one (:func:`write_profile`). Values are written with ``repr`` precision, so a replayed
profile gives the very same numbers.
"""

from __future__ import annotations

import json
import math
import os
import sys
from collections.abc import Mapping
from pathlib import Path

from .. import __version__
from ..runtime.atomic import atomic_write
from ..runtime.json_io import dumps
from ..runtime.provenance import read_provenance, record_in

__all__ = ["PROFILE_KEYS", "profile_from_settings", "read_profile", "write_profile"]

#: the keys of a profile (the options of ``skin-indent fit`` without dashes)
PROFILE_KEYS = ("model", "fix", "prior", "free", "method", "window", "radius", "mesh", "noise", "contact", "start",
                "tol", "index", "surface")
#: names the provenance settings and the API use, and the profile key each one is
ALIASES = {"fixed": "fix", "priors": "prior", "window_mm": "window", "radius_mm": "radius", "noise_mN": "noise",
           "x0": "start"}
#: recorded settings that describe a run but set nothing (the radii a batch found; the version)
INFORMATIONAL = ("radii_mm", "skin_indent")
CHOICES = {"method": ("ekf-paper", "ekf", "lsq"), "mesh": ("coarse", "medium", "fine"),
           "contact": ("auto", "fit", "origin")}


def _number(name: str, value, *, positive: bool = False, allow_inf: bool = False) -> float:
    if isinstance(value, bool):
        raise ValueError(f"{name} must be a number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if math.isnan(number) or (math.isinf(number) and not allow_inf) or (positive and not number > 0):
        raise ValueError(f"{name} must be a {'positive ' if positive else ''}finite number, got {value!r}")
    return number


def _pair(name: str, value, sep: str) -> list[float]:
    items = value.split(sep) if isinstance(value, str) else value
    if not isinstance(items, (list, tuple)) or len(items) != 2:
        raise ValueError(f"{name} must be two numbers, got {value!r}")
    return [_number(name, v) for v in items]


def _named(name: str, value, sep: str | None) -> dict:
    """``{"nu": 0.45}`` or ``["nu=0.45"]`` (``sep`` splits a prior's ``MEAN:SD``) as a dict."""
    if isinstance(value, Mapping):
        items = list(value.items())
    elif isinstance(value, (list, tuple)) and all(isinstance(v, str) and "=" in v for v in value):
        items = [tuple(v.split("=", 1)) for v in value]
    else:
        raise ValueError(f"{name} must be a table NAME = VALUE, got {value!r}")
    out = {}
    for key, v in items:
        key = str(key).strip()
        if not key:
            raise ValueError(f"{name}: empty parameter name")
        if sep is None:
            out[key] = _number(f"{name} {key}", v, allow_inf=True)
        else:
            mean, sd = _pair(f"{name} {key}", v, sep)
            if not sd > 0:
                raise ValueError(f"{name} {key}: the SD must be > 0, got {sd!r}")
            out[key] = [mean, sd]
    return out


def _value(key: str, value):
    if key in ("model", "surface"):
        if not isinstance(value, str) or not value.strip():
            raise ValueError(f"{key} must be a non-empty string, got {value!r}")
        return value.strip()
    if key in CHOICES:
        if value not in CHOICES[key]:
            raise ValueError(f"{key} must be one of {', '.join(CHOICES[key])}, got {value!r}")
        return value
    if key == "free":
        names = [value] if isinstance(value, str) else value
        if not isinstance(names, (list, tuple)) or any(n != "nu" for n in names):
            raise ValueError(f"free must be a list of parameters the scale's default holds (nu), got {value!r}")
        return sorted(set(names))
    if key == "fix":
        return _named(key, value, None)
    if key == "prior":
        return _named(key, value, ":")
    if key == "window":
        lo, hi = _pair(key, value, ":")
        if not 0 <= lo < hi:
            raise ValueError(f"window must satisfy 0 <= MIN < MAX, got {value!r}")
        return [lo, hi]
    if key == "start":
        return _pair(key, value, ",")
    if key == "index":
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ValueError(f"index must be an integer >= 0, got {value!r}")
        return value
    return _number(key, value, positive=True)  # radius, noise, tol


def profile_from_settings(settings: Mapping) -> dict:
    """A profile (the keys of :data:`PROFILE_KEYS`, values checked) from a mapping of settings.

    Parameters
    ----------
    settings : mapping
        A profile, or the ``settings`` of a provenance record (names as in :data:`ALIASES`).
        A ``None`` value (an option not given) is left out.

    Returns
    -------
    dict

    Raises
    ------
    ValueError
        One line naming the key, for an unknown key or a value of the wrong kind.
    """
    if not isinstance(settings, Mapping):
        raise ValueError(f"a profile is a table of settings, got {type(settings).__name__}")
    out: dict = {}
    for raw, value in settings.items():
        key = ALIASES.get(raw, raw)
        if raw in INFORMATIONAL or value is None or (key in ("fix", "prior", "free") and not value):
            continue
        if key not in PROFILE_KEYS:
            raise ValueError(f"unknown setting {raw!r} (a fit profile takes {', '.join(PROFILE_KEYS)})")
        if key in out:
            raise ValueError(f"{key!r} is given twice (as {raw!r} too)")
        out[key] = _value(key, value)
    return out


def _settings_of(obj, name: str) -> Mapping:
    """The settings a parsed profile file holds: itself, or the ``settings`` of a provenance record."""
    record = record_in(obj) if isinstance(obj, Mapping) else {}
    if record:
        if not isinstance(record.get("settings"), Mapping):
            raise ValueError(f"{name}: its provenance record has no settings")
        return record["settings"]
    return obj


def read_profile(path) -> dict:
    """The fit settings of a profile file, or of any output of a fit that carries its provenance.

    Parameters
    ----------
    path : path
        A profile (``.json``, or ``.toml`` with Python >= 3.11); a fit's JSON output (its
        ``provenance``); a fit CSV, batch TSV (their ``#`` provenance header) or fit PNG.

    Returns
    -------
    dict
        The profile (:func:`profile_from_settings`).

    Raises
    ------
    ValueError
        One line naming the file: missing or unreadable, not JSON/TOML, TOML without
        :mod:`tomllib`, no provenance header, an unknown key or a bad value.
    """
    p = Path(os.fspath(path))
    name = f"profile {p}"
    try:
        raw = p.read_bytes()
    except OSError as err:
        raise ValueError(f"{name}: {' '.join((err.strerror or str(err)).split())}") from None
    try:
        if raw.startswith(b"\x89PNG"):
            obj = read_provenance(p)
            if not obj:
                raise ValueError("the figure holds no provenance")
        elif p.suffix.lower() == ".toml":
            if sys.version_info < (3, 11):
                raise ValueError("a TOML profile needs Python >= 3.11 (tomllib); write it as JSON")
            import tomllib

            try:
                obj = tomllib.loads(raw.decode("utf-8"))
            except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
                raise ValueError(f"not TOML ({' '.join(str(err).split())})") from None
        else:
            text = raw.decode("utf-8-sig")
            if text.lstrip().startswith("#"):
                obj = read_provenance(text.splitlines())
                if not obj:
                    raise ValueError("its # lines hold no provenance header")
            else:
                try:
                    obj = json.loads(text)
                except json.JSONDecodeError as err:
                    raise ValueError(f"not JSON (line {err.lineno}, column {err.colno}: {err.msg})") from None
        return profile_from_settings(_settings_of(obj, name))
    except UnicodeDecodeError:
        raise ValueError(f"{name}: not UTF-8 text") from None
    except ValueError as err:
        raise ValueError(f"{name}: {err}") from None


def _toml_value(value) -> str:
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a TOML basic string
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"no TOML for {type(value).__name__}")


def write_profile(profile: Mapping, path) -> Path:
    """Write a profile: TOML for a ``.toml`` file, else JSON (atomically).

    Parameters
    ----------
    profile : mapping
        Checked with :func:`profile_from_settings`.
    path : path

    Returns
    -------
    Path
    """
    prof = profile_from_settings(profile)
    p = Path(os.fspath(path))
    if p.suffix.lower() == ".toml":
        tables = {k: v for k, v in prof.items() if isinstance(v, dict)}
        lines = [f"# skin-indent fit profile (skin_indent {__version__})"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in prof.items() if k not in tables]
        for k, table in tables.items():
            lines += ["", f"[{k}]"] + [f"{json.dumps(n)} = {_toml_value(v)}" for n, v in table.items()]
        text = "\n".join(lines) + "\n"
    else:
        text = dumps(prof, indent=1) + "\n"
    return atomic_write(p, lambda fh: fh.write(text.encode("utf-8")))
