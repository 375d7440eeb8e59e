"""The run scheduler of the finite-element model in the loop: meshes, warm starts, workers, the run cache.

:class:`~skin_indent.models.fe_core.FECore` says which unit-modulus runs a fit needs (the
parameters, the tolerance, the solved depths); a :class:`RunScheduler` makes them:

- **meshes**: a mesh is built once for reference interfaces and morphed for others within
  :data:`MORPH_RANGE` (:meth:`RunScheduler.reference`, :meth:`RunScheduler.built`), so the force is a
  smooth function of the thicknesses;
- **warm starts**: a run starts Newton's method at every depth from the converged fields of the
  nearest run made before on a mesh of the same topology (:meth:`RunScheduler.warm_start`);
- **workers**: several runs go to local processes at once, and within :meth:`RunScheduler.in_workers`
  a single one too (fits side by side in threads share the cores);
- **the run cache**: with a :class:`~skin_indent.response_surface.RunCache` every run is kept on disk,
  keyed by everything that determines it (:meth:`RunScheduler.run_parts`), and read instead of solved.

It knows nothing of the fit's parameters: it takes runs as :class:`Run` (a sample at unit
modulus and how to solve it) under keys the core chooses, and keeps their curves by key.
"""

from __future__ import annotations

import collections
import contextlib
import sys
import time
import weakref
from dataclasses import dataclass

import numpy as np

from ..mechanics.layers import LayeredSample
from ..response_surface import RunFailed
from ..response_surface.run_cache import module_digest
from ..runtime.executors import available_cpus, make_executor
from . import fe_runs
from .fe_runs import as_arrays, from_arrays, morph, solve_unit, solved_depths

__all__ = ["MORPH_RANGE", "WARM_DISTANCE", "WARM_KEPT", "Run", "RunScheduler"]

#: a thickness may move by these factors before the mesh is rebuilt for it
MORPH_RANGE = (0.8, 1.25)
#: a run starts Newton's method at every depth from the converged fields of the nearest run made
#: before on a mesh of the same topology (morphed from the same reference) when no core parameter
#: after E differs by more than this fraction (of its value, or of 5% of its range near 0); see
#: :meth:`RunScheduler.warm_start`
WARM_DISTANCE = 0.2
#: converged fields of this many recent runs are kept per core for warm starts (~0.5 MB each)
WARM_KEPT = 12


@dataclass(frozen=True)
class Run:
    """One unit-modulus run a core asks for.

    Attributes
    ----------
    rest : ndarray
        The core parameters after E (``nu``, effect fit values): what warm starts compare.
    sample : Material or LayeredSample
        The sample at E = 1 kPa (unmerged layers: the mesh follows every interface).
    rtol : float
        Newton tolerance.
    sensitivities : bool
        Solve the direct-differentiation sensitivities too.
    increments : int
        Solved depths.
    first : float
        First solved depth, as a fraction of the ceiling.
    """

    rest: np.ndarray
    sample: object
    rtol: float
    sensitivities: bool
    increments: int
    first: float


class RunScheduler:
    """Makes the runs of one finite-element core (see the module docstring).

    Parameters
    ----------
    radius_mm : float
        Sphere radius (mm).
    ceiling_mm : float
        Depth every run reaches (mm).
    mesh : str
        Mesh family member.
    lower, upper : ndarray
        Ranges of the core parameters after E (what "nearest" means for warm starts).
    workers : int, optional
        Local processes (default the available cores, at most 2).
    run_cache : RunCache, optional

    Attributes
    ----------
    curves : dict
        ``{key: (h (mm), F at E = 1 kPa (mN), sensitivities or None)}`` of the runs made.
    failed : dict
        ``{key: error}`` of runs that did not converge (not made again).
    runs, made, cached, warm_starts : int
        Runs asked for; solved here; read from the run cache; started from a nearby run's fields.
    run_time_s : float
        Wall time of them all (s).
    """

    def __init__(self, radius_mm: float, ceiling_mm: float, mesh: str, lower, upper, *,
                 workers: int | None = None, run_cache=None):
        self.radius_mm = float(radius_mm)
        self.ceiling_mm = float(ceiling_mm)
        self.mesh_name = mesh
        self.lower, self.upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
        self.workers = workers
        self.run_cache = run_cache
        self.curves: dict = {}
        self.failed: dict = {}
        self.in_workers_now = False
        self.cancelled = False
        self._refs: dict = {}  # topology (interfaces, rigid base) -> (serial, its reference interfaces)
        self._ref_serial = 0  # counts the reference meshes: morphs of one share its topology
        self._meshes = collections.OrderedDict()  # serial -> the mesh built for that reference
        self._fields = collections.OrderedDict()  # recent runs: key -> (rest, reference serial, {depth: field})
        self._executor = None
        self.runs = self.made = self.cached = self.warm_starts = 0
        self.run_time_s = 0.0

    # ----------------------------------------------------------------- meshes
    def reference(self, sample) -> tuple:
        """The mesh reference of a sample: ``(serial, interfaces (mm) or None)``.

        Each topology (the number of interfaces, a rigid base or not) keeps its reference (the
        interfaces a mesh is built for) while a sample of it has each interface within
        :data:`MORPH_RANGE` of the reference's; otherwise the sample's interfaces are that
        topology's new reference (``serial`` counts references: the meshes of one share its
        topology). A run of another topology in between (a rigid base's and the finite base of
        its slope, :meth:`~.fe_core.FECore.jacobian`) leaves it: one reference for all bodies
        made two runs of a rigid base apart on two meshes (their difference, a Jacobian's column,
        was the meshes' and a fit's steps met their discretisation, measured: two layers on a
        rigid base stopped by the step tolerance at chi2 80.4, 69.9, 61.9 after restarts).
        Nothing is built here: a run read from the run cache needs no mesh.
        """
        if not isinstance(sample, LayeredSample):
            key, interfaces = (0, False), None
        else:
            interfaces = np.asarray(sample.interfaces_mm, dtype=float)
            key = (interfaces.size, sample.rigid_base)
        have = self._refs.get(key)
        if have is not None:
            if interfaces is None:
                return have
            ratio = interfaces / have[1]
            if np.all((ratio >= MORPH_RANGE[0]) & (ratio <= MORPH_RANGE[1])):
                return have
        self._ref_serial += 1
        self._refs[key] = (self._ref_serial, interfaces)
        return self._refs[key]

    def built(self, serial: int, reference, sample):
        """The mesh of reference ``serial`` (built once, for the interfaces ``reference``), morphed to the
        interfaces of ``sample``."""
        from ..mechanics.mesh import graded_mesh  # scikit-fem, loaded when a run is first solved

        imesh = self._meshes.get(serial)
        if imesh is None:
            if reference is None:
                imesh = graded_mesh(self.radius_mm, self.ceiling_mm, self.mesh_name)
            elif sample.rigid_base:
                imesh = graded_mesh(self.radius_mm, self.ceiling_mm, self.mesh_name, interfaces_mm=reference[:-1],
                                    rigid_base_mm=float(reference[-1]))
            else:
                imesh = graded_mesh(self.radius_mm, self.ceiling_mm, self.mesh_name, interfaces_mm=reference)
            self._meshes[serial] = imesh
            while len(self._meshes) > 4:
                self._meshes.popitem(last=False)
        if reference is None:
            return imesh
        interfaces = np.asarray(sample.interfaces_mm, dtype=float)
        if np.array_equal(interfaces, reference):
            return imesh
        return morph(imesh, reference, interfaces, sample.rigid_base)

    def mesh(self, sample):
        """The mesh a run of ``sample`` is solved on (built, or morphed from its reference's)."""
        serial, reference = self.reference(sample)
        return self.built(serial, reference, sample)

    def reset_mesh(self) -> None:
        """Build the mesh anew for the next runs (a new reference for morphing)."""
        self._refs.clear()

    # ----------------------------------------------------------------- workers
    @contextlib.contextmanager
    def in_workers(self):
        """Within the block every run goes to the worker processes, a single one too, and this
        process only waits for it (re-entrant)."""
        before, self.in_workers_now = self.in_workers_now, True
        try:
            yield self
        finally:
            self.in_workers_now = before

    def start_workers(self) -> None:
        """Start the worker processes now, from the calling thread (the main one, before threads
        that make runs in them start: :meth:`~skin_indent.runtime.executors.LocalProcesses.start`)."""
        self.pool().start()

    def pool(self):
        """The worker processes (made on first use, closed with this object)."""
        if self._executor is None:
            workers = self.workers if self.workers is not None else min(2, available_cpus())
            self._executor = make_executor(workers)
            weakref.finalize(self, self._executor.close)
        return self._executor

    def close(self) -> None:
        """Stop the worker processes."""
        if self._executor is not None:
            self._executor.close()
            self._executor = None

    # ----------------------------------------------------------------- runs
    def make(self, todo: dict) -> tuple | None:
        """Make the runs ``todo`` (``{key: Run}``) and keep their curves under their keys; the first
        run that failed as ``(key, error)`` (its failure kept in :attr:`failed`), else None."""
        if self.cancelled:
            raise RuntimeError("the finite-element fit was cancelled")
        where = {}
        for key, run in todo.items():
            serial, reference = self.reference(run.sample)
            where[key] = (np.array(run.rest, dtype=float), serial, reference)  # the mesh is built only if solved
        failed = None
        t0 = time.perf_counter()
        for key, value in self._solve(todo, where).items():
            if isinstance(value, BaseException):
                self.failed[key] = value
                failed = failed or (key, value)
            else:
                self.curves[key] = value
        self.runs += len(todo)
        self.run_time_s += time.perf_counter() - t0
        return failed

    def warm_start(self, rest, serial: int, depths) -> list | None:
        """The converged fields (one per depth of ``depths``, None where it has none) of the nearest
        run kept (:data:`WARM_KEPT`) on a mesh of reference ``serial`` whose core parameters after E
        are within :data:`WARM_DISTANCE` of ``rest``; None if there is no such run.

        Newton's method then starts at every depth from a state converged for a nearby sample
        instead of the predictor's: measured on the forearm-like two layers and layer with
        stiffening (coarse mesh, 14 depths), 1 iteration per depth instead of 4-7 for a
        finite-difference step, 2-3 for a step of 1-5% in a thickness or a modulus ratio, runs
        2.5-5x cheaper, forces within 1e-8 of a cold run (the Newton tolerance).
        """
        rest = np.asarray(rest, dtype=float)
        scale = np.maximum(np.abs(rest), 0.05 * (self.upper - self.lower))
        best, best_d = None, WARM_DISTANCE
        for key, (other, other_serial, fields) in self._fields.items():
            if other_serial != serial:
                continue
            d = float(np.max(np.abs(other - rest) / scale))
            if d <= best_d:
                best, best_d = key, d
        if best is None:
            return None
        fields = self._fields[best][2]
        initial = [fields.get(float(h)) for h in depths]
        return initial if any(f is not None for f in initial) else None

    def _keep_fields(self, key, rest, serial: int, fields) -> None:
        self._fields[key] = (rest, serial, {float(h): u for h, u in fields})
        self._fields.move_to_end(key)
        while len(self._fields) > WARM_KEPT:
            self._fields.popitem(last=False)

    def _arguments(self, run: Run, imesh, initial=None) -> tuple:
        """The arguments of :func:`~.fe_runs.solve_unit` for ``run`` on the mesh ``imesh``."""
        return (run.sample, self.radius_mm, self.ceiling_mm, imesh, run.rtol, run.sensitivities, run.increments,
                run.first, initial)

    def _compute(self, todo: dict, where: dict, keys: list):
        """Solve the runs ``keys`` of ``todo`` (``where``: their parameters and mesh references):
        ``(key, run, error)`` as they finish (one alone here, unless :meth:`in_workers`; several in
        the worker processes), each on its mesh (built here), warm-started from the nearest run made
        before (:meth:`warm_start`); their converged fields are kept for the next, in the order of
        ``keys`` once all have finished."""
        tasks = {}
        for key in keys:
            run = todo[key]
            rest, serial, reference = where[key]
            imesh = self.built(serial, reference, run.sample)
            depths = solved_depths(run.sample, self.ceiling_mm, run.increments, run.first)
            initial = self.warm_start(rest, serial, depths)
            self.warm_starts += initial is not None
            tasks[key] = self._arguments(run, imesh, initial)

        finished = {}

        def done(key, value, error):
            if error is not None:
                return key, None, error
            h, F, S, fields = value
            finished[key] = zip(h, fields)
            return key, (h, F, S), None

        if len(keys) == 1 and not self.in_workers_now:
            key = keys[0]
            try:
                value = solve_unit(*tasks[key])
            except Exception as err:  # noqa: BLE001 - a run that does not converge is a failed evaluation
                yield key, None, err
            else:
                yield done(key, value, None)
        elif keys:
            for key, value, error in self.pool().imap_unordered(solve_unit, tasks.items()):
                yield done(key, value, error)
        # kept in the order asked, not the order the workers finished: the next warm starts (the nearest
        # kept, the oldest dropped first) and so every fit in the loop are the same from run to run
        for key in keys:
            if key in finished:
                self._keep_fields(key, *where[key][:2], finished[key])

    def run_parts(self, run: Run, reference_mm) -> dict:
        """The key parts (:meth:`~skin_indent.response_surface.RunCache.key`) of ``run`` on a mesh
        morphed from one built for the interfaces ``reference_mm`` (None: a half-space): the sample
        as built, the sphere radius, the depths solved (the increments and the first depth), the
        mesh (its family member, the reference and the base; with the sample's interfaces and the
        sources they determine its nodes), the Newton tolerance, the sensitivities or not, and the
        digest of this module and of :mod:`.fe_runs` (which solve and morph). A warm start
        (:meth:`warm_start`) is not part of it: it changes the result only to the Newton tolerance."""
        reference = None if reference_mm is None else [float(v) for v in reference_mm]
        return {"run": "skin_indent.models.fe_core unit-modulus run",
                "code": module_digest(sys.modules[__name__], fe_runs),
                "sample": repr(run.sample), "radius_mm": self.radius_mm, "ceiling_mm": self.ceiling_mm,
                "increments": int(run.increments), "first": float(run.first),
                "depth_mm": solved_depths(run.sample, self.ceiling_mm, run.increments, run.first).tolist(),
                "mesh": self.mesh_name, "mesh_reference_mm": reference,
                "mesh_rigid_base": bool(getattr(run.sample, "rigid_base", False)),
                "rtol": float(run.rtol), "sensitivities": bool(run.sensitivities)}

    def _solve(self, todo: dict, where: dict) -> dict:
        """``{key: run or exception}`` of the runs ``todo`` (``{key: Run}``; ``where``:
        ``{key: (rest, mesh serial, reference interfaces)}``): read from the run cache where it has them
        (a run with sensitivities also serves one without, when that one was not made itself: a rerun
        reads what the first run read, to the bit), else solved (and kept there)."""
        if not todo:
            return {}
        if self.run_cache is None:
            out = {key: value if error is None else error
                   for key, value, error in self._compute(todo, where, list(todo))}
            self.made += len(out)
            return out
        out, parts = {}, {}
        for key, run in todo.items():
            parts[key] = self.run_parts(run, where[key][2])
            if not run.sensitivities:  # without sensitivities: its own run, else the run with them serves too
                with contextlib.suppress(RunFailed):
                    arrays = self.run_cache.load(self.run_cache.key(parts[key]))
                    if arrays is None:
                        arrays = self.run_cache.load(self.run_cache.key({**parts[key], "sensitivities": True}))
                    if arrays is not None:
                        out[key] = from_arrays(arrays, False)
        rest = {key: p for key, p in parts.items() if key not in out}
        before = dict(self.run_cache.counts)

        def compute(keys):
            for key, run, error in self._compute(todo, where, keys):
                yield key, None if run is None else as_arrays(run), error

        for key, value in self.run_cache.get_or_compute_many(rest, compute).items():
            out[key] = value if isinstance(value, BaseException) else from_arrays(value, todo[key].sensitivities)
        solved = sum(self.run_cache.counts[k] - before[k] for k in ("computed", "failed"))
        self.made += solved
        self.cached += len(todo) - solved
        return out
