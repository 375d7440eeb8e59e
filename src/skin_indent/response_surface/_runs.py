"""Making the missing forward runs of one or more run stores, each once across processes.

A :class:`~skin_indent.response_surface.ResponseSurface` (one store: a run per nu) and an
:class:`~skin_indent.models.effect_surface.EffectSurface` (one store per node of its effect axes, all
their runs in one stream so that every worker stays busy) make their runs here:

- a run is made only under its lock (:meth:`RunStore.claim`), after reading the store
  again: a run another builder finished meanwhile is read, not made;
- each result is recorded as it arrives, by this process alone, whichever executor made
  it; a run that failed is recorded with its reason;
- a run from a remote worker (Dask) made with other forward-model sources than its
  settings name is refused, as a failure naming both digests;
- runs another builder holds are waited for, then read, or made here if it left them
  undone.

:func:`choose_executor` picks what runs them: the executor given, a Dask cluster, local
processes, or this process.
"""

from __future__ import annotations

import logging
import pickle
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..runtime.executors import Executor, import_distributed, make_executor
from ..runtime.log import progress_bar
from ._cache import expected_code_of, run_key, run_task
from ._store import RunStore

log = logging.getLogger(__name__)

__all__ = ["Job", "choose_executor", "make_runs"]


@dataclass(frozen=True)
class Job:
    """One forward run to make.

    Attributes
    ----------
    tag : hashable
        The caller's name for it (``k``, the nu's column; ``(node, nu)``).
    store : RunStore or None
        Where it is kept (None: nothing is written, the run is made here).
    nu : float
        Its Poisson's ratio (the store's entry).
    args : tuple
        ``(unit_curve, nu, depth_mm)`` of :func:`~skin_indent.response_surface.run_task`.
    expected_code : str or None
        The forward-model source digest its settings name (checked on remote workers).
    """

    tag: object
    store: RunStore | None
    nu: float
    args: tuple
    expected_code: str | None = None


def choose_executor(unit_curve, workers, client, scheduler, executor, n_todo) -> tuple[Executor, bool]:
    """``(executor, owned)`` of a stream of ``n_todo`` runs of ``unit_curve``: the given one, Dask,
    local processes or this process (one run, or a callable that cannot be pickled and no
    ``workers`` asked for). ``owned``: made here, to be closed after the stream."""
    if executor is not None:
        if workers is not None or client is not None or scheduler is not None:
            raise ValueError("give executor= alone, without workers=, client= or scheduler=")
        if not isinstance(executor, Executor):
            raise TypeError(f"executor must be a skin_indent Executor, got {type(executor).__name__}")
        executor.check_callable(unit_curve)
        return executor, False
    if client is not None or scheduler is not None:
        ex = make_executor(workers, client=client, scheduler=scheduler)
        try:
            ex.check_callable(unit_curve)
        except BaseException:
            ex.close()
            raise
        return ex, True
    if workers is None or workers > 1:
        try:
            pickle.dumps(unit_curve)
        except Exception as exc:
            if workers is not None:
                raise TypeError(f"unit_curve cannot be pickled for workers={workers} ({exc}); use a "
                                "module-level function or a functools.partial of one, or workers=1") from None
            workers = 1
    if n_todo <= 1:
        workers = 1
    return make_executor(workers, tasks=n_todo), True


def make_runs(jobs: list[Job], executor_for: Callable, *, bar, what: str) -> Iterator[tuple]:
    """Make the runs of ``jobs``; yield ``(tag, values, reason)`` for each (``values`` None: failed).

    Parameters
    ----------
    jobs : list of Job
    executor_for : callable
        ``executor_for(n_runs) -> (executor, owned)``: the executor of a stream of ``n_runs``
        runs, closed here after the stream if ``owned``.
    bar : progress bar
        Advanced by one for every run yielded.
    what : str
        The surface in log lines.
    """
    pending = list(jobs)
    while pending:
        busy: list[Job] = []  # runs another builder is computing
        claims: dict = {}  # tag -> the run's lock, held while it is computed here
        done_meanwhile: list[tuple] = []
        by_tag = {job.tag: job for job in pending}
        tasks = _claimed(pending, busy, claims, done_meanwhile)
        ex, owned = executor_for(len(pending))
        try:
            for tag, out, error in ex.imap_unordered(run_task, tasks):
                while done_meanwhile:
                    bar.update()
                    yield done_meanwhile.pop()
                job = by_tag[tag]
                bar.update()
                try:
                    yield tag, *_record(job, out, error, remote=ex.remote)
                finally:
                    if tag in claims:
                        claims.pop(tag).release()
            while done_meanwhile:
                bar.update()
                yield done_meanwhile.pop()
        finally:
            for lock in claims.values():
                lock.release()
            if owned:
                ex.close()
        pending = busy
        if pending:  # other builders compute these: wait for them, then take what they left
            log.info("%s: waiting for %d run%s another process is computing", what, len(pending),
                     "s" if len(pending) != 1 else "")
            for job in pending:
                job.store.claim(job.nu, wait=True).release()


def _claimed(jobs, busy: list, claims: dict, done_meanwhile: list):
    """The tasks ``(tag, args)`` of the runs of ``jobs`` to make here: each claimed under its lock
    (kept in ``claims``) and not done meanwhile (those go to ``done_meanwhile`` as results); the
    runs another builder holds go to ``busy``."""
    for job in jobs:
        if job.store is not None:
            lock = job.store.claim(job.nu)
            if lock is None:
                busy.append(job)
                continue
            job.store.refresh()  # under the run's lock: is it done meanwhile? (a stat, or a re-read)
            values = job.store.load(job.nu)
            if values is not None:
                lock.release()
                done_meanwhile.append((job.tag, values, None))
                continue
            claims[job.tag] = lock
        yield job.tag, job.args


def _record(job: Job, out, error, *, remote: bool) -> tuple:
    """``(values, reason)`` of a run that came back, recorded in its store."""
    reason, worker = None, None
    if error is not None:  # the call did not come back (worker died, ...)
        why = " ".join(str(error).split())
        reason = f"{type(error).__name__}: {why}" if why else type(error).__name__
    elif remote and job.expected_code is not None and out["code"] != job.expected_code:
        reason = (f"worker {out['worker']} runs other forward-model sources (src.{out['code']}, expected "
                  f"src.{job.expected_code}): install the same skin_indent everywhere")
        worker = out["worker"]
    elif out["values"] is None:
        reason, worker = out["reason"], out["worker"]
    if reason is not None:
        if job.store is not None:
            job.store.record_failed(job.nu, reason, worker=worker)
        return None, reason
    if job.store is not None:  # streamed to disk now
        job.store.record_done(job.nu, out["values"], seconds=out["seconds"], cpu_seconds=out.get("cpu_seconds"),
                              worker=out["worker"])
    return out["values"], None


def surface_columns(grid, unit_curve, settings, what: str, *, cache_dir=None, workers=None, progress=None,
                    client=None, scheduler=None, executor=None, quiet: bool = False) -> tuple[np.ndarray, dict]:
    """The unit forces of a response surface, one run per nu, read from the run cache or made.

    Parameters are those of :meth:`~skin_indent.response_surface.ResponseSurface.build` (``unit_curve``
    and ``settings`` resolved); ``what`` names the surface in log lines.

    Returns
    -------
    f : ndarray
        Unit forces (mN at E = 1 kPa), depths x nu; the column of a failed run is NaN.
    failures : dict
        nu -> why its run failed (each also warned as a RuntimeWarning).
    """
    if (client is not None or scheduler is not None) and executor is None:
        import_distributed()  # fail with the install hint before any output
    depth = np.array(grid.depth_mm)
    nus = grid.nu
    f = np.full((depth.size, nus.size), np.nan)
    key = run_key(settings, depth)
    store = None if cache_dir is None else RunStore(Path(cache_dir) / "runs" / key[:24], key, settings, depth)
    todo = []
    for k, nu in enumerate(nus.tolist()):
        done = store.load(nu) if store is not None else None
        if done is None:
            todo.append(k)
        else:
            f[:, k] = done
    failures: dict[float, str] = {}
    if todo:  # one line for the phase (the cache folder in a DEBUG line)
        (log.debug if quiet else log.info)("%s: %d finite-element run%s to make, %d of %d cached", what,
                                           len(todo), "s" if len(todo) != 1 else "", nus.size - len(todo),
                                           nus.size)
        if store is not None:
            log.debug("%s: runs cached in %s", what, store.dir)
    else:
        log.debug("%s: all %d runs cached (or shipped) in %s", what, nus.size, store.dir)
    bar = progress_bar(progress, total=nus.size, initial=nus.size - len(todo), desc="response surface",
                       unit="run")
    # remote workers may run another installation: what they ran is checked (local processes run
    # this one, which may be edited meanwhile in development)
    code = expected_code_of(settings)
    jobs = [Job(k, store, float(nus[k]), (unit_curve, float(nus[k]), depth), code) for k in todo]
    try:
        for k, values, reason in make_runs(jobs, lambda n: choose_executor(unit_curve, workers, client, scheduler,
                                                                             executor, n), bar=bar, what=what):
            if values is None:
                failures[float(nus[k])] = reason
                warnings.warn(f"forward run at nu = {float(nus[k]):g} failed ({reason}); column left missing",
                              RuntimeWarning, stacklevel=3)
            else:
                f[:, k] = values
    finally:
        bar.close()
    return f, failures
