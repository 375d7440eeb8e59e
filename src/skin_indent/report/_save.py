"""The one way the package writes a figure: :func:`save_figure`, a PNG with its provenance.

Every PNG of :mod:`skin_indent.report` and of the demo goes through here, so each carries the
record of how it was made (:func:`skin_indent.runtime.provenance.png_metadata`: package
version, command line or API call, inputs with sha256, settings) in its text chunks, and
is written atomically (mode 0644 under the usual umask).
"""

from __future__ import annotations

import io
from pathlib import Path

from ..runtime.atomic import atomic_write
from ..runtime.provenance import png_metadata

__all__ = ["save_figure"]


def save_figure(fig, path, prov: dict | None = None, *, dpi: int = 110) -> Path:
    """Write ``fig`` as a PNG with the provenance ``prov`` in its metadata.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : path
        The PNG file.
    prov : dict, optional
        From :func:`skin_indent.runtime.provenance.provenance`; read it back with
        :func:`skin_indent.runtime.provenance.read_provenance`.
    dpi : int
        Resolution, dots per inch.

    Returns
    -------
    Path
    """
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata=png_metadata(prov))
    return atomic_write(path, lambda fh: fh.write(buf.getvalue()))
