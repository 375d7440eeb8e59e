"""Shared by the benchmark scripts: make ``skin_indent`` importable from a checkout."""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
try:  # installed (pip install -e .) or run from a checkout
    import skin_indent  # noqa: F401
except ImportError:  # pragma: no cover - depends on the environment
    sys.path.insert(0, str(ROOT / "src"))
    import skin_indent  # noqa: F401


def write_results(results: dict, out: Path) -> Path:
    """Write ``results`` as JSON to ``out``; ``benchmarks/results/`` is kept out of git."""
    import json

    out.parent.mkdir(parents=True, exist_ok=True)
    if out.parent == HERE / "results" and not (out.parent / ".gitignore").exists():
        (out.parent / ".gitignore").write_text("*\n")
    out.write_text(json.dumps(results, indent=2, default=float) + "\n")
    print(f"\nwritten {out}")
    return out
