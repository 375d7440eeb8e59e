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
from collections.abc import Callable, Iterator
from dataclasses import dataclass

from ..runtime.executors import Executor, make_executor
from ._cache import run_task
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
