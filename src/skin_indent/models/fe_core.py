"""The elastic force of any combination of elastic effects, with the finite-element model in the loop.

A response surface covers the base model and each elastic effect alone. Two layers
(dermis over hypodermis over muscle), a layer with strain stiffening, or any other
combination would need a surface over every parameter at once (thousands of runs), so
:class:`FECore` evaluates the finite-element model itself at the parameters a fit asks
for. It is an elastic core of :class:`~skin_indent.models.ComposedModel` like a surface
(``parameter_names``, ``bounds``, ``depth_range``, ``force``), so offsets, relaxation
and adhesion act on it as on a surface.

What keeps it cheap and smooth:

- **One run per parameter set, any depth.** The force is exactly proportional to the
  modulus of the top material (every other modulus is relative to it), so one
  unit-modulus run (E = 1 kPa) to the depth ceiling serves every E, and the force at
  any depth comes from the spline of F / h^1.5 over the solved increments, as in
  :func:`~skin_indent.simulate.simulate`; a contact-point offset costs no run.
- **A mesh that moves with the layers.** The mesh is built once for reference
  thicknesses and *morphed* for others (depths mapped piecewise linearly so every
  interface moves to its new depth and every quadrature point stays in its material),
  so the force is a smooth function of the thicknesses and finite differences in them
  are meaningful. It is rebuilt when a thickness leaves [0.8, 1.25] x its reference.
- **Finite differences in parallel.** :meth:`FECore.prefetch` runs the parameter sets
  of a Jacobian at once on the local processes of the :class:`~skin_indent.Context`.
- **Sensitivities with every run.** A fit asks for the Jacobian at almost every point it
  evaluates, so each run of :meth:`FECore.force` also solves for the sensitivities (one
  adjoint solve per depth, +15-20% of a run, instead of a second run); a held parameter
  costs no run (``jacobian(..., columns=)``).
- **Fits side by side.** The fits of several combinations on top of one rung (two layers,
  layer and stiffening) run at once, each in a thread whose runs go to worker processes
  (:meth:`FECore.in_workers`): a fit's evaluations are serial, so one fit alone leaves a
  core idle between its Jacobians.
- **Cheap screening.** Start vectors are ranked by runs with fewer solved depths and a
  looser tolerance (:meth:`FECore.screening`), kept apart from the fit's runs.
- **Warm starts.** A run starts Newton's method at every depth from the converged fields of
  the nearest run made before on a mesh of the same topology (:meth:`~.fe_scheduler.RunScheduler.warm_start`):
  the steps of a fit and its finite differences are then 2.5-5x cheaper (1-3 Newton
  iterations per depth instead of 4-7 on layers), the forces the same to the Newton tolerance.
- **A run cache.** With a :class:`~skin_indent.response_surface.RunCache` (``run_cache``) every
  run is kept on disk, keyed by everything that determines it: the same fit or diagnosis made
  again (another process, another day) solves nothing.
- **Secant updates of the differenced columns.** Within a fit's iterations
  (:meth:`FECore.iterating`, entered by :func:`~skin_indent.inverse.fit_least_squares`) a
  thickness column is carried from one Jacobian to the next by a Broyden update and made
  afresh by runs only every :data:`~.fe_jacobian.SECANT_REFRESH` Jacobians; the covariance after the
  fit uses exact differences. Measured on the forearm-like two-layer fit below: 77 -> 53
  runs, 62.6 -> 54-60 s (the differenced runs were made two at a time; the serial runs of
  the evaluations, ~2 s each, are most of a fit).

On the forearm-like curve (100 loading points, two layers, 6 parameters, coarse mesh, 2
cores; benchmarks/diagnose.py ``--ladder``, one quiet machine) one fit took 166 s and 98 runs
before these two measures, 57 s and 80 runs after them (to the same optimum, RMS 0.0531 mN, a
rigid base under the second layer), and 87 s and 50 runs once the screen ranked every start at
its best modulus (:meth:`~skin_indent.fitting.multistart.Fitter`): a better optimum, RMS 0.0510
mN, with the muscle a half-space as in the truth, whose deep interface makes each run 3-5x dearer.
"""

from __future__ import annotations

import contextlib

import numpy as np

from ..effects import ELASTIC, ForwardSpec, instances, model_name
from ..effects.base import stack_parameters
from ..response_surface import nice_depth
from .fe_jacobian import RELATIVE_STEP
from .fe_jacobian import jacobian as fe_jacobian
from .fe_runs import FIRST, INCREMENTS
from .fe_scheduler import Run, RunScheduler

#: Newton tolerance of the runs in the loop: finite differences of relative step
#: :data:`~.fe_jacobian.RELATIVE_STEP` need forces converged far below the step
RTOL = 1e-8
#: solved depths of the runs within the iterations of a fit (:meth:`FECore.iterating`); the
#: fit's result (force, Jacobian, covariance) comes from a run of :data:`INCREMENTS` at its
#: end. Against runs of 40 on the coarse mesh (100 depths to 0.6 mm; one layer, two layers,
#: layer and stiffening): within 3.5e-3 at 0.05 mm, 1.9e-3 beyond 0.1 mm and 0.004 mN
#: anywhere, as 20 are (1.8e-3 to 2.9e-3, 0.003 mN: the coarse mesh's own scatter as the
#: contact edge crosses nodes), at 0.75-0.8x their cost. Not used for what the data
#: determine: on a shallow half-space curve (0.15 mm) their Jacobian's nu column differs
#: from E's by more than the physics does (E then looked determined; with 20 it is not)
FIT_INCREMENTS = 14
#: Poisson's ratio range of the runs in the loop
NU_RANGE = (0.2, 0.499)
#: runs that only rank the start vectors of a fit (:meth:`FECore.screening`): fewer solved
#: depths and a looser Newton tolerance; never used by the fit itself. Measured on the
#: forearm-like two layers: 12 depths from 1% of the ceiling were within 2.5e-3 of the fit's
#: runs beyond 0.1 mm (0.03 mN at 11 mN, below the noise of such curves); 8 depths over the
#: same range were 2.2% off (5x that noise); the tolerance (1e-5 to 1e-8) changes nothing
#: visible. The screen solves the same geometric steps (x1.53) from 5% of the ceiling
#: (:data:`SCREEN_FIRST`), the force below that extrapolated: on the forearm-like curve the
#: 24 starts of layer+layer and of layer+stiffening rank with the same four first (three are
#: kept) as with the 12 depths, at 0.75x the time
SCREEN_INCREMENTS, SCREEN_RTOL, SCREEN_FIRST = 8, 1e-5, 0.05
#: a layer's compliance (its modulus / the modulus below it) under which the base below is not
#: solved: between a rigid base (compliance below 1e-6, the layer's own rule) and this one the force
#: is linear in the compliance, from the rigid base's run to this one's (:meth:`FECore.force`). Runs of
#: a base that much stiffer do not converge (measured: two layers at nu 0.49, the second's compliance
#: 1e-6, 2e-6, 1e-5, 1e-4: Newton fails after 8 step cuts, 40-85 s each; 1e-3: 82 s; 1e-2: 3 s);
#: a fit leaving a rigid base (:meth:`FECore.jacobian`'s slope there) steps into that range
STIFF_BASE = 1e-2


class FECore:
    """Elastic force F(h; E, nu, fit parameters of the elastic effects) by finite-element runs.

    Parameters
    ----------
    effects : sequence of str or Effect
        The model's effects; the elastic ones (:data:`~skin_indent.effects.ELASTIC`) are
        this core's, repeats allowed (``("layer", "layer")``).
    radius_mm : float
        Sphere radius, mm.
    max_depth_mm : float
        Deepest indentation to cover, mm (the runs reach a little further, so that a
        contact-point offset can move the curve).
    e_star_kPa : float
        Hertz estimate of E / (1 - nu^2), kPa: the range of E is E*/30 to 30 E*.
    mesh : str
        Mesh family member (``"coarse"`` in diagnosis).
    workers : int, optional
        Local processes for :meth:`prefetch` (default: the available cores, at most 2 per
        Jacobian's worth of runs is typical).
    run_cache : RunCache, optional
        Where finished runs are kept across processes
        (:class:`~skin_indent.response_surface.RunCache`): a run found there is read, not
        solved. Default None: runs are kept in this object only.

    Attributes
    ----------
    runs : int
        Finite-element runs used so far (solved here or read from ``run_cache``); ``made`` of
        them solved here, ``cached`` read; ``run_time_s`` the wall time of both.
    """

    #: the runs are made during the fit (the protocol of :class:`~skin_indent.models.core.ElasticCore`)
    in_loop = True

    def __init__(self, effects, *, radius_mm: float, max_depth_mm: float, e_star_kPa: float, mesh: str = "coarse",
                 workers: int | None = None, run_cache=None):

        self.effects = tuple(e for e in instances(effects) if e.stage == ELASTIC)
        self.radius_mm = float(radius_mm)
        self.ceiling_mm = nice_depth(1.15 * float(max_depth_mm))
        self.depth_range = (0.0, self.ceiling_mm)
        self.mesh_name = mesh
        self.workers = workers
        names, lo, hi = ["E_kPa", "nu"], [e_star_kPa / 30.0, NU_RANGE[0]], [e_star_kPa * 30.0, NU_RANGE[1]]
        reach = nice_depth(float(max_depth_mm))
        self._slices = stack_parameters(self.effects, lambda e: e.fe_bounds(reach), names, lo, hi)
        #: the coordinates of theta that are a layer's compliance (0: a rigid base below it)
        self._compliances = tuple(s.start + getattr(e, "inner", e).fit_names.index("compliance")
                                  for e, s in self._slices if "compliance" in getattr(e, "inner", e).fit_names)
        self.parameter_names = tuple(names)
        self.bounds = (np.array(lo, dtype=float), np.array(hi, dtype=float))
        self.relative_step = RELATIVE_STEP
        self._screening = False
        self._secant, self._last = False, None
        self.scheduler = RunScheduler(self.radius_mm, self.ceiling_mm, mesh, self.bounds[0][1:], self.bounds[1][1:],
                                      workers=workers, run_cache=run_cache)

    @property
    def name(self) -> str:
        return "finite elements in the loop: " + model_name(self.effects)

    # ----------------------------------------------------------------- parameters
    def spec(self, rest) -> ForwardSpec:
        """The unit-modulus :class:`ForwardSpec` of the core parameters after E (``nu``, effect fit values)."""
        rest = np.asarray(rest, dtype=float)
        spec = ForwardSpec(1.0, float(rest[0]))
        for e, s in self._slices:
            fit = dict(zip(e.fit_names, rest[s.start - 1:s.stop - 1]))
            e.configure(spec, e.from_fit(fit, 1.0))
        return spec

    def body(self, rest) -> str:
        """The body of the core parameters after E (``nu``, effect fit values) up to its modulus:
        two parameter vectors with the same body give forces in the ratio of their E (a second
        layer under a rigid base, or of the first one's modulus, is the one-layer body)."""
        return repr(self.spec(rest).sample())

    def _check(self, theta) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        if theta.shape != (len(self.parameter_names),):
            raise ValueError(f"theta must hold {self.parameter_names}, got shape {theta.shape}")
        lo, hi = self.bounds
        bad = ~np.isfinite(theta) | (theta < lo - 1e-12 * np.abs(lo)) | (theta > hi + 1e-12 * np.abs(hi))
        if np.any(bad):
            i = int(np.argmax(bad))
            raise ValueError(f"{self.parameter_names[i]} = {theta[i]:g} is outside [{lo[i]:g}, {hi[i]:g}] of the "
                             f"finite-element fit")
        return theta

    # ----------------------------------------------------------------- runs (the scheduler's)
    def _key(self, rest) -> tuple:
        key = tuple(float(f"{v:.12g}") for v in np.asarray(rest, dtype=float))
        if self._screening:
            return ("screen",) + key
        return ("iterating",) + key if self._secant else key

    @property
    def _curves(self) -> dict:
        return self.scheduler.curves

    @contextlib.contextmanager
    def screening(self):
        """Within the block, runs only rank start vectors: :data:`SCREEN_INCREMENTS` solved
        depths from :data:`SCREEN_FIRST` of the ceiling at Newton tolerance :data:`SCREEN_RTOL`,
        kept apart from the fit's runs."""
        self._screening = True
        try:
            yield self
        finally:
            self._screening = False

    def in_workers(self):
        """Within the block every run goes to the worker processes, a single one too, and this
        process only waits for it: fits of several cores, each in a thread of this process
        (:meth:`~skin_indent.fitting.multistart.Fitter.fit_all`), then share the cores."""
        return self.scheduler.in_workers()

    def start_workers(self) -> None:
        """Start the worker processes now, from the calling thread (the main one, before threads
        that make runs in them start)."""
        self.scheduler.start_workers()

    def cancel(self) -> None:
        """Refuse every further run (``RuntimeError``): a fit in another thread stops at its next
        run when the diagnosis is interrupted."""
        self.scheduler.cancelled = True

    def reset_mesh(self) -> None:
        """Build the mesh anew for the next parameters (a new reference for morphing)."""
        self.scheduler.reset_mesh()

    def prefetch(self, thetas) -> None:
        """Make the runs of several parameter vectors (full ``theta``) at once, in parallel."""
        self._run([t[1:] for theta in thetas for t in self._solved(self._check(theta))])

    def _stiff(self, theta) -> tuple | None:
        """``(i, rigid, stiff, w)`` when the compliance ``theta[i]`` lies between a rigid base and
        :data:`STIFF_BASE`, where the base below is not solved: the force is ``(1 - w)`` times that
        at ``rigid`` (compliance 0) plus ``w`` times that at ``stiff`` (compliance :data:`STIFF_BASE`);
        None when no compliance does."""
        for i in self._compliances:
            if 0.0 < theta[i] < STIFF_BASE:
                rigid, stiff = theta.copy(), theta.copy()
                rigid[i], stiff[i] = 0.0, STIFF_BASE
                if self.spec(theta[1:]).sample(merge=False) != self.spec(rigid[1:]).sample(merge=False):
                    return i, rigid, stiff, float(theta[i]) / STIFF_BASE
        return None

    def _solved(self, theta) -> list:
        """The parameter vectors whose runs give the force at ``theta``: itself, or the ends of its
        stiff-base range (:meth:`_stiff`), each in turn."""
        stiff = self._stiff(theta)
        return [theta] if stiff is None else self._solved(stiff[1]) + self._solved(stiff[2])

    def _run(self, rests, sensitivities: bool = False) -> None:
        """Have the scheduler make the runs of the core parameters after E ``rests`` that it has not made."""
        runs = self.scheduler
        if runs.cancelled:
            raise RuntimeError("the finite-element fit was cancelled")
        todo = {}
        failed = None
        for rest in rests:
            key = self._key(rest)
            if key in runs.failed:  # a run that did not converge is not made again
                failed = failed or (key, runs.failed[key])
                continue
            have = runs.curves.get(key)
            if (have is None or (sensitivities and have[2] is None)) and key not in todo:
                todo[key] = self.run_of(rest, sensitivities)
        failed = runs.make(todo) or failed
        if failed is not None:  # one line for the fits: this start or step is not evaluated
            key, err = failed
            values = ", ".join(f"{n} = {v:.4g}" for n, v in zip(self.parameter_names[1:], key[-len(rests[0]):]))
            raise ValueError(f"finite-element run failed at {values}: {str(err).splitlines()[0]}")

    def run_of(self, rest, sensitivities: bool = False) -> Run:
        """The :class:`~.fe_scheduler.Run` of the core parameters after E ``rest``: the unit-modulus
        sample, solved as a screen's run, a fit's iteration's or a result's."""
        sample = self.spec(rest).sample(merge=False)
        rest = np.array(rest, dtype=float)
        if self._screening:
            return Run(rest, sample, SCREEN_RTOL, False, SCREEN_INCREMENTS, SCREEN_FIRST)
        return Run(rest, sample, RTOL, sensitivities, FIT_INCREMENTS if self._secant else INCREMENTS, FIRST)

    def run_parts(self, run: Run, reference_mm) -> dict:
        """The run cache's key parts of ``run`` (:meth:`~.fe_scheduler.RunScheduler.run_parts`)."""
        return self.scheduler.run_parts(run, reference_mm)

    @property
    def runs(self) -> int:
        return self.scheduler.runs

    @property
    def made(self) -> int:
        return self.scheduler.made

    @property
    def cached(self) -> int:
        return self.scheduler.cached

    @property
    def warm_starts(self) -> int:
        return self.scheduler.warm_starts

    @property
    def run_time_s(self) -> float:
        return self.scheduler.run_time_s

    @property
    def run_cache(self):
        return self.scheduler.run_cache

    def unit_force(self, depth_mm, rest, *, sensitivities: bool = True) -> np.ndarray:
        """Force (mN) at E = 1 kPa of the core parameters after E, at depths 0 < h <= ceiling (mm).

        A new run also computes the sensitivities (``sensitivities``, +15-20% of its time):
        a fit asks for the Jacobian at most points it evaluates, which then costs no run.
        """
        from ..simulate import not_a_knot_spline

        if self._key(rest) not in self._curves:
            self._run([rest], sensitivities=sensitivities and not self._screening)
        h_s, F_s, _ = self._curves[self._key(rest)]
        h = np.asarray(depth_mm, dtype=float)
        return not_a_knot_spline(h_s, F_s / h_s**1.5, h) * h**1.5

    def force(self, depth_mm, theta, *, sensitivities: bool = True) -> np.ndarray:
        """Force (mN) at depths 0 < h <= ``depth_range[1]`` (mm).

        A layer's compliance between a rigid base (below 1e-6) and :data:`STIFF_BASE` (a base
        more than 100 times stiffer than the layer) is not solved: the force there is linear in
        it, from the rigid base's to that of :data:`STIFF_BASE` (continuous at both ends; against a
        run at 1e-3 of the forearm-like two layers: 0.17 %, the coarse mesh's own scatter)."""
        theta = self._check(theta)
        h = np.asarray(depth_mm, dtype=float)
        if np.any(h <= 0) or np.any(h > self.ceiling_mm * (1 + 1e-9)):
            raise ValueError(f"depths must lie in (0, {self.ceiling_mm:g}] mm for this finite-element fit")
        stiff = self._stiff(theta)
        if stiff is not None:
            _, rigid, base, w = stiff
            self.prefetch([rigid, base])  # the two ends' runs at once
            return ((1 - w) * self.force(h, rigid, sensitivities=sensitivities)
                    + w * self.force(h, base, sensitivities=sensitivities))
        return theta[0] * self.unit_force(h, theta[1:], sensitivities=sensitivities)

    @contextlib.contextmanager
    def iterating(self):
        """Within the block (the iterations of a fit), runs solve :data:`FIT_INCREMENTS` depths
        and the finite-difference columns of :meth:`jacobian` are carried from one Jacobian to
        the next by secant (Broyden) updates, recomputed by fresh runs only every
        :data:`~.fe_jacobian.SECANT_REFRESH` Jacobians; outside it (the fit's result, a covariance, a
        suggestion) runs solve :data:`INCREMENTS` depths and every Jacobian is exact."""
        self._secant, self._last = True, None
        try:
            yield self
        finally:
            self._secant, self._last = False, None

    def jacobian(self, depth_mm, theta, columns=None) -> np.ndarray:
        """dF/dtheta (mN per unit) at depths 0 < h <= ceiling.

        Exact in E (F is proportional to it); by direct differentiation of the run where
        a parameter acts on the material parameters only (nu, moduli ratios, C20 / E: the
        chain rule through the cheap map from ``theta`` to the materials); by one-sided
        differences of finite-element runs (made at once, in parallel, on a morphed mesh)
        where it moves the geometry (a thickness) or changes the set of materials (a rigid base).
        Only the ``columns`` asked for are computed (default all; the others are 0): a fit
        makes no runs for the parameters it holds. Within :meth:`iterating`, the differenced
        columns are secant updates between fresh differences (:mod:`.fe_jacobian`).
        """
        return fe_jacobian(self, depth_mm, theta, columns)

    def _stiff_jacobian(self, h, theta, columns, i: int, rigid, stiff, w: float) -> np.ndarray:
        """The Jacobian where the compliance ``theta[i]`` lies in its stiff-base range (:meth:`_stiff`):
        the other columns weighed as the force is from the ends' Jacobians (each exact: no secant
        update across two bodies), column ``i`` the slope of the line between them."""
        cols = np.arange(theta.size) if columns is None else np.arange(theta.size)[columns]
        others = np.array([j for j in cols if j != i], dtype=int)
        self._run([t[1:] for t in self._solved(rigid) + self._solved(stiff)], sensitivities=True)
        self._last = None
        J = (1 - w) * self.jacobian(h, rigid, columns=others) + w * self.jacobian(h, stiff, columns=others)
        self._last = None
        if i in cols:
            J[:, i] = (self.force(h, stiff) - self.force(h, rigid)) / STIFF_BASE
        return J

    def close(self) -> None:
        """Stop the worker processes."""
        self.scheduler.close()
