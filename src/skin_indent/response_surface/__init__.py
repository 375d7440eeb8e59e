r"""Response surface F(h; E, nu) of sphere indentation, cached and interpolated.

After Delalleau et al. (2006): the force-depth curve is tabulated on a grid of depths
``h`` (mm), Young's moduli ``E`` (kPa) and Poisson's ratios ``nu`` and interpolated by
cubic Lagrange polynomials, with analytic gradients for the inversion.

For the neo-Hookean half-space ``F(h; E, nu) = E f(h; nu)`` exactly, so a surface needs
one forward run per ``nu`` (the *unit curve* ``f``, force in mN at E = 1 kPa), not one
per ``(E, nu)`` pair. The forward model is reached through one callable,
``unit_curve(nu, depth_mm) -> force_mN``; the default one,
:func:`skin_indent.simulate.fe_unit_curve`, is imported only when a build needs it.

Interpolation
-------------
Before interpolating, the unit forces are divided by a known shape (``scaling``):

* ``"hertz"`` (default): :math:`g = f\,(1-\nu^2)/h^{3/2}`, the ratio to the Hertz
  shape. Hertz is exact as h -> 0, so ``g`` is smooth and nearly constant in both h and
  nu, and the interpolation only has to carry the large-strain correction.
* ``"h1.5"``: :math:`g = f/h^{3/2}` (removes the contact singularity only).
* ``"none"``: :math:`g = f`, the paper's scheme applied to the force itself.

All three are linear in the data, so F stays exactly proportional to E. Max relative
error of F, 0.05 <= h <= 0.6 mm, 117 nu in [0.2, 0.49], on :meth:`SurfaceGrid.paper`
(``method/depth_interp``; columns: the test stand-in
``f = 4/3 sqrt(R) h^1.5 (1 - (0.15 + 0.3 (0.5 - nu)) h/R) / (1 - nu^2)``, R = 6.22 mm,
and a "wavy" variant times ``1 + 0.05 sin(6 nu) sqrt(h/0.6)``, not polynomial in h or nu):

================  =======  =======  =========  =======  =======  =========
scaling           stand-in                     wavy
----------------  ---------------------------  ---------------------------
(nu / depth)      lag/lag  spl/spl  lag/quart  lag/lag  spl/spl  lag/quart
================  =======  =======  =========  =======  =======  =========
``hertz``         4e-15    2e-15    6e-14      2.9e-5   2.0e-5   5.1e-4
``h1.5``          6.9e-5   5.2e-5   6.9e-5     8.0e-5   6.0e-5   5.2e-4
``none`` (paper)  6.9e-5   5.2e-5   3.4e-2     8.0e-5   6.0e-5   3.4e-2
================  =======  =======  =========  =======  =======  =========

The stand-in's Hertz ratio is linear in h and nu, hence exact with ``hertz``. Without
dividing by h^1.5, depth interpolation near the contact point is poor: at h = 0.009 mm
(between the first two nodes) the error on F is 1.8e-3 (Lagrange), 1.4e-3 (spline) and
0.9 (global quartic), against < 1e-15 on F/h^1.5 and 6e-13 / 4e-13 / 2.5e-9 on F^(2/3)
(a nonlinear alternative, not implemented). On the FElupe reference curve
(E = 8 kPa, nu = 0.45; every second depth dropped and re-interpolated) the error is set
by the curve's own roughness: 6-8e-4 for every variant at h >= 0.05 mm, except the
quartic of F (2.9e-2); below 0.05 mm, 1.5e-3 with h^1.5 scaling against 6-8e-3 for F.
With ``scaling="none"`` depths below the first node are rejected (extrapolating F
there is off by up to 30 %); otherwise they are extrapolated in the smooth ratio.

Building at scale
-----------------
:meth:`ResponseSurface.build` hands the forward runs to an :class:`Executor`: this
process (``workers=1``), local processes (default, :class:`LocalProcesses`), or a Dask
cluster (``client=`` a ``dask.distributed.Client``, or ``scheduler="tcp://HOST:PORT"``;
``pip install 'skin_indent[dask]'``). Whichever runs them, results come back to the
building process, which alone writes the run cache (``cache_dir``), one run at a time,
as they arrive: see :class:`RunStore` for the manifest, checksums and the lock that
let a killed build resume without recomputing finished runs and several builds share
one cache. A run that fails (``ConvergenceError``, bad values, a worker that died) is
listed with its reason, its column is NaN, interpolation that needs it says so, and
the next build retries it (:func:`make_runs`, which the effect surfaces of
:mod:`skin_indent.models` share). :func:`run_batch` runs other batches of forward runs the
same way.

A fresh install does not start from nothing: the runs of the surfaces its default workflows
need (the neo-Hookean half-space at unit radius, the base, layer and stiffening surfaces of the
bundled skin curves at R = 6.22 and 3.11 mm) are shipped with the package and read like the
run cache, when verified for the installed forward model (:mod:`~skin_indent.response_surface.shipped`:
verified by recomputed forces, accepted by source digest).

Single runs outside the surfaces (the finite-element model in the loop of a fit, the
checks and suggestions of a diagnosis) are kept by a :class:`RunCache`
(:mod:`~skin_indent.response_surface.run_cache`), one file per run keyed by everything
that determines it, so that the same diagnosis run again solves nothing.
"""


from ._cache import (default_cache_dir, default_settings, default_unit_curve, expected_code_of, resolve_model, run_key,
                     run_task, settings_hash)
from ..runtime.executors import (DASK_MISSING, DaskExecutor, Executor, InProcess, LocalProcesses, WorkerDied, make_executor,
                         run_batch)
from ._grid import NICE_DEPTHS, SurfaceGrid, nice_depth, parse_range
from ._runs import Job, make_runs
from ._store import RunStore
from .run_cache import RunCache, RunFailed
from ._core import SurfaceCore
from ._interpolation import DEPTH_INTERPS, METHODS, SCALINGS, NodeForces
from ._surface import ResponseSurface

__all__ = [
    "resolve_model", "run_key", "run_task", "expected_code_of", "Job", "make_runs",
    "NICE_DEPTHS", "nice_depth",
    "SurfaceGrid",
    "ResponseSurface",
    "SurfaceCore",
    "NodeForces",
    "parse_range",
    "default_settings",
    "default_unit_curve",
    "default_cache_dir",
    "settings_hash",
    "METHODS",
    "DEPTH_INTERPS",
    "SCALINGS",
    "Executor",
    "InProcess",
    "LocalProcesses",
    "DaskExecutor",
    "WorkerDied",
    "make_executor",
    "run_batch",
    "RunStore",
    "RunCache",
    "RunFailed",
    "DASK_MISSING",
]
