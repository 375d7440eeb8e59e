"""Reading a data file's bytes, with one-line errors for what a user can get wrong."""

from __future__ import annotations

from pathlib import Path

from ._errors import MeasurementError


def read_bytes(path: Path, kind: str) -> bytes:
    """The bytes of ``path``; a one-line :class:`MeasurementError` if it is missing, a folder
    (not a file of the ``kind`` named) or unreadable. What the bytes hold is the reader's to check."""
    name = path.name or str(path)
    if path.is_dir():
        raise MeasurementError(f"{name}: is a directory, not a {kind}")
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise MeasurementError(f"{path}: file not found") from None
    except PermissionError:
        raise MeasurementError(f"{path}: permission denied") from None
    except OSError as err:
        raise MeasurementError(f"{path}: cannot be read ({err.strerror or err})") from None
    return raw


def folder_files(folder: Path, suffixes, *, recursive: bool = False, skip=None) -> list[Path]:
    """The files of ``folder`` whose names end with one of ``suffixes`` (any case), sorted by path.

    Hidden files and folders (names starting with ``.``) are left out, and files for which
    ``skip(path)`` is true. ``recursive``: the subfolders' files too (every depth; a folder's
    files sort before its subfolders' only by path, ``a/x.csv`` < ``a/sub/y.csv``).
    """
    suffixes = tuple(s.lower() for s in suffixes)
    found = folder.rglob("*") if recursive else folder.iterdir()
    out = []
    for q in found:
        rel = q.relative_to(folder).parts
        if any(part.startswith(".") for part in rel) or not q.is_file():
            continue
        if q.name.lower().endswith(suffixes) and not (skip and skip(q)):
            out.append(q)
    return sorted(out)
