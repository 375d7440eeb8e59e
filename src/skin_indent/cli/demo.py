"""``skin-indent demo``: the paper's workflow and the diagnosis on the bundled forearm-like curve."""

from __future__ import annotations

from pathlib import Path

from .options import progress_of

def add_demo(sub):
    p = sub.add_parser("demo", help="the paper's workflow on the bundled in-vivo-like curve",
                       description="Identify (E, nu) of the bundled forearm-like curve with the paper's EKF and "
                                   "global stabilisation, a better-conditioned EKF and least squares; then "
                                   "diagnose what the homogeneous half-space misses (the ladder); write figures.")
    p.add_argument("--out", type=Path, default=Path("skin_indent_demo"), help="output folder (default skin_indent_demo)")
    p.add_argument("--workers", type=int, default=None, help="local processes for building the surface")
    p.add_argument("--no-diagnosis", action="store_true",
                   help="stop after the paper's workflow (the diagnosis ladder builds effect surfaces and fits "
                        "with the finite-element model in the loop: minutes on 2 cores)")
    p.set_defaults(run=_run_demo)


def _run_demo(args) -> int:
    from ..demo import run_demo

    run_demo(args.out, workers=args.workers, diagnosis=not args.no_diagnosis, progress=progress_of(args),
             command=args.command_line)
    return 0

