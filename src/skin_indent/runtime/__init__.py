"""Runtime plumbing shared by every part of the package: where work runs and what it leaves.

- :mod:`.context`: :class:`Context`, where surfaces are cached and built (cache folder,
  local processes, a Dask cluster, progress);
- :mod:`.executors`: local processes, in-process runs and Dask behind one interface;
- :mod:`.threads`: BLAS threads per process and the worker environment;
- :mod:`.log`: the ``skin_indent`` logger's output on the command line, progress bars;
- :mod:`.atomic`: files written whole or not at all;
- :mod:`.json_io`: the one JSON encoder (NaN and infinity as null, arrays as lists);
- :mod:`.provenance`: version, libraries, command, inputs with sha256 and settings of
  every file the package writes.
"""

from .atomic import atomic_write
from .context import Context, context_of
from .json_io import dumps, jsonable

__all__ = ["Context", "atomic_write", "context_of", "dumps", "jsonable"]
