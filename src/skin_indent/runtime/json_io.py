"""The one JSON encoder of the package: every ``to_dict`` and every JSON file goes through it.

NaN (an undefined number, e.g. the standard deviation of a fixed parameter) becomes
``null``; +-inf (a meaningful value, e.g. the modulus ratio of a rigid base) becomes the
string ``"inf"`` / ``"-inf"``; numpy scalars and arrays become Python numbers and lists.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping

import numpy as np


def jsonable(obj):
    """``obj`` as JSON-safe Python objects (see the module docstring)."""
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        f = float(obj)
        if math.isnan(f):
            return None
        if math.isinf(f):
            return "inf" if f > 0 else "-inf"
        return f
    if obj is None or isinstance(obj, str):
        return obj
    return str(obj)


def dumps(obj, **kwargs) -> str:
    """``json.dumps`` of :func:`jsonable` (never NaN or Infinity in the text)."""
    return json.dumps(jsonable(obj), allow_nan=False, **kwargs)
