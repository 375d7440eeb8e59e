"""Where batches of forward runs execute: this process, local processes, or Dask.

An :class:`Executor` runs picklable calls ``fn(*args)`` and hands back the outcomes in
completion order through :meth:`Executor.imap_unordered`. The caller consumes the
outcomes in its own (submitting) process, so that it alone writes results to disk as
they arrive: a killed worker, or a killed caller, loses only the runs not yet finished.

* :class:`InProcess`: one call after the other, here (no pickling).
* :class:`LocalProcesses`: a :class:`concurrent.futures.ProcessPoolExecutor`. At most
  ``2 * workers`` calls are in flight, so memory does not grow with the batch. A worker
  process that dies (killed, out of memory, a crash in native code) breaks the pool:
  it is restarted and the calls in flight are retried one at a time; a call that kills
  its worker twice when running alone is reported as failed (:class:`WorkerDied`).
  Each worker uses one BLAS thread (:mod:`skin_indent.runtime.threads`: set in its environment
  when it starts and by its initializer), and this process one while they run.
* :class:`DaskExecutor`: a ``dask.distributed.Client``, given or connected to a
  scheduler address (``tcp://HOST:PORT``). Dask is optional (``pip install
  'skin_indent[dask]'``) and imported only here. The scheduler reschedules the calls
  of a worker that dies; a call that keeps killing workers comes back as Dask's
  ``KilledWorker``. Every worker needs the same ``skin_indent`` installed. Before the
  first call each worker undoes the nanny's ``MALLOC_TRIM_THRESHOLD_`` (see
  :func:`tune_malloc`), which would slow the finite-element model ~1.8x, and limits its
  BLAS threads to one (:func:`skin_indent.runtime.threads.init_worker`).

:func:`make_executor` picks one from the ``workers``, ``client`` and ``scheduler``
arguments that :meth:`ResponseSurface.build` takes.
"""

from __future__ import annotations

import collections
import os
import pickle
from typing import Any, Callable, Hashable, Iterable, Iterator

from .threads import WORKER_THREADS, init_worker, limit_threads, worker_environment

Outcome = tuple  # (tag, value or None, exception or None)

DASK_MISSING = "Dask is not installed: pip install 'skin_indent[dask]'"
#: Seconds to wait for a Dask scheduler given by address.
DASK_CONNECT_TIMEOUT_S = 20


class WorkerDied(RuntimeError):
    """A call killed the process that ran it (or that process died for another reason)."""


def available_cpus() -> int:
    """CPUs this process may run on (affinity-aware)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


_MALLOC_TUNED = False


def tune_malloc() -> bool:
    """Undo the allocator setting that Dask's nanny gives its workers, once per process.

    The nanny starts workers with ``MALLOC_TRIM_THRESHOLD_=65536``. Setting any trim
    threshold switches off glibc's dynamic mmap threshold, so every large numpy
    temporary is mmapped and page-faulted afresh: the finite-element model then runs
    ~1.8x slower (5.4 s -> 9.7 s for 4 coarse runs, measured). This sets
    ``M_MMAP_THRESHOLD`` = 32 MiB and ``M_TRIM_THRESHOLD`` = 128 MiB (at most 128 MiB of
    freed heap is kept per worker). Only on glibc, and only if ``MALLOC_TRIM_THRESHOLD_``
    is set and ``MALLOC_MMAP_THRESHOLD_`` is not; True if it changed anything.
    """
    global _MALLOC_TUNED
    if _MALLOC_TUNED:
        return False
    _MALLOC_TUNED = True
    if "MALLOC_TRIM_THRESHOLD_" not in os.environ or "MALLOC_MMAP_THRESHOLD_" in os.environ:
        return False
    try:
        import ctypes
        import ctypes.util

        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
        return bool(libc.mallopt(M_MMAP_THRESHOLD, 32 << 20)) and bool(libc.mallopt(M_TRIM_THRESHOLD, 128 << 20))
    except (OSError, AttributeError):  # not glibc
        return False


def _call_tuned(fn, *args):
    """``fn(*args)`` on a Dask worker, after :func:`tune_malloc`, with one BLAS thread (:func:`_call_limited`)."""
    tune_malloc()
    return _call_limited(fn, *args)


def _call_limited(fn, *args):
    """``fn(*args)`` on a Dask worker, with one BLAS thread (set once per process)."""
    init_worker(WORKER_THREADS)
    return fn(*args)


def import_distributed():
    try:
        import distributed
    except ImportError:
        raise ImportError(DASK_MISSING) from None
    return distributed


class Executor:
    """Runs ``fn(*args)`` for a stream of tasks; outcomes come back as they finish.

    Subclasses implement :meth:`imap_unordered`. Use as a context manager (or call
    :meth:`close`) to release what the executor started.
    """

    #: short description for messages and benchmark output
    name = "executor"
    #: True if calls may run on other machines, with another installation of skin_indent:
    #: a build then refuses results computed with other forward-model sources than its
    #: settings' ``code_version`` names
    remote = False

    def slots(self) -> int:
        """How many calls run at once (an estimate for remote clusters)."""
        return 1

    def check_callable(self, fn: Callable) -> None:
        """Raise ``TypeError`` if ``fn`` cannot be shipped to where it would run."""

    def imap_unordered(self, fn: Callable, tasks: Iterable[tuple[Hashable, tuple]]) -> Iterator[Outcome]:
        """Run ``fn(*args)`` for each ``(tag, args)`` of ``tasks``; yield ``(tag, value, error)``.

        ``tasks`` is consumed lazily, as slots free up, so a generator may decide at
        the last moment that a task is no longer needed. ``error`` is the exception
        the call raised (``value`` is then None), or a :class:`WorkerDied` /
        Dask ``KilledWorker`` when the process running it died. ``KeyboardInterrupt``
        and other ``BaseException`` of an in-process call propagate. Leaving the
        iteration early cancels what has not started.
        """
        raise NotImplementedError

    def start(self) -> None:
        """Start what runs the calls now, from the calling thread (nothing to start by default)."""

    def close(self) -> None:
        """Release processes or connections that this executor opened."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        return f"{type(self).__name__}({self.name})"


class InProcess(Executor):
    """Run each call in this process, in order."""

    name = "in-process"

    def imap_unordered(self, fn, tasks):
        for tag, args in tasks:
            try:
                value = fn(*args)
            except Exception as exc:  # noqa: BLE001 - reported to the caller, which decides
                yield tag, None, exc
            else:
                yield tag, value, None


class LocalProcesses(Executor):
    """Run calls in ``workers`` local processes (``concurrent.futures``).

    Parameters
    ----------
    workers : int
        Number of processes (>= 1).
    in_flight : int, optional
        Calls submitted at once; default ``2 * workers``.
    mp_context : multiprocessing context, optional
        Passed to :class:`~concurrent.futures.ProcessPoolExecutor`.
    """

    #: a call that broke the pool this many times while running alone is given up
    MAX_CRASHES = 2

    def __init__(self, workers: int, *, in_flight: int | None = None, mp_context=None):
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
        self.workers = workers
        self.in_flight = max(1, in_flight or 2 * workers)
        self._mp_context = mp_context
        self._pool = None
        self.name = f"{workers} local process{'es' if workers > 1 else ''}"
        self.restarts = 0  # pools replaced after a worker died

    def slots(self):
        return self.workers

    def check_callable(self, fn):
        try:
            pickle.dumps(fn)
        except Exception as exc:
            raise TypeError(f"unit_curve cannot be pickled for workers={self.workers} ({exc}); use a "
                            "module-level function or a functools.partial of one, or workers=1") from None

    def _new_pool(self):
        from concurrent.futures import ProcessPoolExecutor  # lazy: multiprocessing is slow to import

        self._pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=self._mp_context,
                                         initializer=init_worker, initargs=(WORKER_THREADS,))
        return self._pool

    def start(self):
        """Start the worker processes now, from the calling thread.

        A pool forks its processes at its first call. Threads that share the cores (fits of
        one examination side by side) would then fork from a thread while another may hold a
        lock, which the child inherits locked (Python warns of this from 3.12 on); started
        here, from the main thread, before those threads run, they never do.
        """
        pool = self._pool or self._new_pool()
        pool.submit(int).result()

    def _drop_pool(self):
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None

    def imap_unordered(self, fn, tasks):
        # the workers take the cores: this process waits with one BLAS thread
        with limit_threads(WORKER_THREADS):
            yield from self._imap_unordered(fn, tasks)

    def _imap_unordered(self, fn, tasks):
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        tasks = iter(tasks)
        queue = collections.deque()  # (tag, args, isolate) to retry after a broken pool
        crashes = collections.Counter()
        pending = {}  # future -> (tag, args, isolate)
        exhausted = False
        fruitless = 0  # pool restarts since a call last came back or was given up

        def restart():
            nonlocal pool, fruitless
            fruitless += 1
            if fruitless > 4:
                raise WorkerDied("local worker processes keep dying before any call finishes (out of memory? "
                                 "process limits?)")
            self._drop_pool()
            self.restarts += 1
            pool = self._new_pool()

        pool = self._pool or self._new_pool()
        try:
            while True:
                # refill; a retried call that may kill its worker runs alone
                while len(pending) < self.in_flight and not any(iso for _, _, iso in pending.values()):
                    if queue:
                        if queue[0][2] and pending:
                            break
                        item = queue.popleft()
                    elif not exhausted:
                        nxt = next(tasks, None)
                        if nxt is None:
                            exhausted = True
                            break
                        item = (nxt[0], nxt[1], False)
                    else:
                        break
                    try:
                        with worker_environment(WORKER_THREADS):  # workers start inside submit
                            pending[pool.submit(fn, *item[1])] = item
                    except BrokenProcessPool:  # a worker died since the last wait: not this call's doing
                        queue.appendleft(item)
                        break
                if not pending:
                    if not queue:
                        return
                    restart()  # broken before anything was in flight
                    continue
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                broken = []
                for fut in done:
                    item = pending.pop(fut)
                    try:
                        value = fut.result()
                    except BrokenProcessPool:
                        broken.append(item)
                    except Exception as exc:  # noqa: BLE001 - the call raised (pickling, ...)
                        fruitless = 0
                        yield item[0], None, exc
                    else:
                        fruitless = 0
                        yield item[0], value, None
                if broken:
                    # every call in flight fails with the pool; we cannot tell which one
                    # killed it unless it ran alone
                    broken.extend(pending.values())
                    pending.clear()
                    restart()
                    if len(broken) == 1:
                        tag, args, _ = broken[0]
                        crashes[tag] += 1
                        if crashes[tag] >= self.MAX_CRASHES:
                            fruitless = 0
                            yield tag, None, WorkerDied(f"the worker process died {crashes[tag]} times running "
                                                        "this call alone (killed, out of memory or crashed)")
                        else:
                            queue.appendleft((tag, args, True))
                    else:
                        queue.extendleft(reversed([(tag, args, True) for tag, args, _ in broken]))
        finally:
            for fut in pending:
                fut.cancel()
            if pending:  # left early (an error, a kill, a break): do not wait for running calls
                self._drop_pool()

    def close(self):
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


class DaskExecutor(Executor):
    """Run calls on a Dask cluster through ``dask.distributed``.

    Parameters
    ----------
    client : dask.distributed.Client, optional
        An existing client; it is left open.
    scheduler : str, optional
        Scheduler address (``tcp://HOST:PORT``); a client is opened here and closed by
        :meth:`close`.
    in_flight : int, optional
        Calls submitted at once; default: all (the scheduler queues them and spreads
        them over the workers, also over workers that join later).
    malloc_tuning : bool
        Call :func:`tune_malloc` on the workers before the first call (default True):
        without it, the finite-element model runs ~1.8x slower under Dask's nanny.
        Starting the workers with ``MALLOC_MMAP_THRESHOLD_`` set does the same.
    """

    remote = True

    def __init__(self, client=None, scheduler: str | None = None, *, in_flight: int | None = None,
                 malloc_tuning: bool = True):
        distributed = import_distributed()
        if (client is None) == (scheduler is None):
            raise ValueError("give exactly one of client= and scheduler=")
        self._own = client is None
        if client is None:
            if not isinstance(scheduler, str) or "://" not in scheduler:
                raise ValueError(f"scheduler must be an address like tcp://HOST:PORT, got {scheduler!r}")
            try:
                client = distributed.Client(scheduler, timeout=DASK_CONNECT_TIMEOUT_S, set_as_default=False)
            except (OSError, TimeoutError) as exc:
                raise OSError(f"cannot connect to the Dask scheduler at {scheduler}: "
                              f"{' '.join(str(exc).split()) or type(exc).__name__}") from None
            except ValueError as exc:
                raise ValueError(f"bad Dask scheduler address {scheduler!r}: {' '.join(str(exc).split())}") from None
        elif not isinstance(client, distributed.Client):
            raise TypeError(f"client must be a dask.distributed.Client, got {type(client).__name__}")
        self.client = client
        self.in_flight = in_flight
        self.malloc_tuning = bool(malloc_tuning)
        self.name = f"Dask at {getattr(client.scheduler, 'address', '?')}"

    def slots(self):
        try:
            return max(1, sum(self.client.nthreads().values()))
        except Exception:  # noqa: BLE001 - an estimate only
            return 1

    def check_callable(self, fn):
        import cloudpickle  # a dependency of distributed

        try:
            cloudpickle.dumps(fn)
        except Exception as exc:
            raise TypeError(f"unit_curve cannot be serialised for Dask ({exc})") from None

    def imap_unordered(self, fn, tasks):
        distributed = import_distributed()
        import uuid

        tasks = iter(tasks)
        batch = uuid.uuid4().hex[:8]
        ac = distributed.as_completed(loop=self.client.loop)
        pending = {}
        exhausted = False
        n = 0

        def refill():
            nonlocal exhausted, n
            while not exhausted and (self.in_flight is None or len(pending) < self.in_flight):
                nxt = next(tasks, None)
                if nxt is None:
                    exhausted = True
                    return
                tag, args = nxt
                n += 1
                call = (_call_tuned if self.malloc_tuning else _call_limited, fn, *args)
                fut = self.client.submit(*call, key=f"skin_indent-{batch}-{n}", pure=False)
                pending[fut] = tag
                ac.add(fut)

        try:
            refill()
            for fut in ac:
                tag = pending.pop(fut)
                try:
                    value = fut.result()
                except Exception as exc:  # noqa: BLE001 - KilledWorker, a failed call, ...
                    yield tag, None, exc
                else:
                    yield tag, value, None
                finally:
                    fut.release()
                refill()
        finally:
            if pending:
                self.client.cancel(list(pending))

    def close(self):
        if self._own and self.client is not None:
            self.client.close()
            self.client = None


def make_executor(workers: int | None = None, *, client=None, scheduler: str | None = None,
                  tasks: int | None = None) -> Executor:
    """The executor for a batch: Dask if ``client`` or ``scheduler`` is given, else local.

    Parameters
    ----------
    workers : int, optional
        Local processes; default ``min(available CPUs, tasks)``. 1 runs in this
        process. Not allowed with Dask (the cluster decides).
    client : dask.distributed.Client, optional
        Run on this client's cluster.
    scheduler : str, optional
        Connect to this Dask scheduler (``tcp://HOST:PORT``).
    tasks : int, optional
        Number of calls planned (caps the default number of processes).

    Raises
    ------
    ImportError
        Dask was asked for but is not installed (the message says how to install it).
    ValueError
        Contradicting arguments.
    """
    if client is not None or scheduler is not None:
        if workers is not None:
            raise ValueError("workers= sets local processes; with a Dask client or scheduler the cluster decides")
        if client is not None and scheduler is not None:
            raise ValueError("give either client= or scheduler=, not both")
        return DaskExecutor(client=client, scheduler=scheduler)
    if workers is None:
        workers = min(available_cpus(), max(1, tasks if tasks is not None else available_cpus()))
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    return InProcess() if workers == 1 else LocalProcesses(workers)


def run_batch(fn: Callable, items: Iterable[tuple], *, workers: int | None = None, client=None,
              scheduler: str | None = None, executor: Executor | None = None) -> list[tuple[Any, BaseException | None]]:
    """Run ``fn(*args)`` for each ``args`` of ``items``; ``[(value, error), ...]`` in input order.

    A convenience for batches of forward runs outside response surfaces (e.g. a
    diagnosis). Arguments as :func:`make_executor`, or an ``executor``.
    """
    items = list(items)
    own = executor is None
    ex = make_executor(workers, client=client, scheduler=scheduler, tasks=len(items)) if own else executor
    out: list = [None] * len(items)
    try:
        for i, value, error in ex.imap_unordered(fn, ((i, args) for i, args in enumerate(items))):
            out[i] = (value, error)
    finally:
        if own:
            ex.close()
    return out
