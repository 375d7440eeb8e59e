"""Many curves at a time, whatever is done to each: the machinery that batches of fits and diagnoses share.

A batch (:func:`skin_indent.batch.fit_many`, :func:`skin_indent.diagnosis.diagnose_many`) reads
its curves in this process, hands one task per curve to the executor of its
:class:`~skin_indent.runtime.context.Context` (this process, local processes or a Dask cluster:
:func:`~skin_indent.runtime.executors.make_executor`) and puts each outcome into its row as it
arrives, here, so that only this process writes results:

- :func:`run_tasks` runs the tasks with a progress bar and yields each outcome, an error as one
  line (a task that raised, a worker that died): a bad curve is a row, never the end of the batch;
- :func:`worker_context` is the context each task works in: the batch's own where the tasks run in
  this process, else one core per task (no process pool inside a worker, where the batch's
  processes already hold the cores and a Dask worker, a daemonic process, may not start one), the
  same cache folder, so that the tasks share the surfaces and runs cached there;
- :class:`BatchRows` is the list of rows with its provenance;
- :func:`one_line` is the error text of a row, :func:`row_provenance` the provenance of a file
  written for one curve.
"""

from __future__ import annotations

import dataclasses
import logging
import os

from .context import Context
from .executors import InProcess, make_executor
from .log import progress_bar

__all__ = ["BatchRows", "one_line", "row_provenance", "run_tasks", "worker_context"]

log = logging.getLogger(__name__)


def one_line(err: BaseException) -> str:
    """The error of a row in one line: the text of a ``ValueError`` (the package's own errors,
    :class:`~skin_indent.measurement.MeasurementError` among them), ``Type: text`` of others."""
    text = " ".join(str(err).split())
    if isinstance(err, ValueError) and text:
        return text
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


def row_provenance(provenance: dict, row) -> dict:
    """The provenance of an output written for one curve of a batch (its plot, its report).

    Parameters
    ----------
    provenance : dict
        The batch's.
    row
        The curve's row (``file`` and ``index``).

    Returns
    -------
    dict
        The batch's, with only the curve's file among the inputs (all of them when it is not
        found there) and ``curve``: ``{"file", "index"}``.
    """
    inputs = provenance.get("inputs", [])
    mine = [i for i in inputs if i.get("path") == os.path.abspath(row.file)]
    return {**provenance, "inputs": mine or inputs, "curve": {"file": row.file, "index": row.index}}


class BatchRows(list):
    """The rows of a batch (one per curve, in file and curve order) and how they were made.

    Each row has ``error`` (one line, empty when the curve was done) and ``flags`` (reasons not
    to trust its numbers). Subclasses set :attr:`columns`, the table's columns.

    Attributes
    ----------
    provenance : dict
        :func:`skin_indent.runtime.provenance.provenance` of the batch: inputs with their sha256,
        settings, command line or API call.
    surfaces : list
        The response surfaces used, where the batch knows them.
    """

    #: the columns of :func:`skin_indent.report.batch_table.write_tsv`, in order
    columns: tuple = ()

    def __init__(self, rows=(), provenance=None, surfaces=()):
        super().__init__(rows)
        self.provenance = provenance or {}
        self.surfaces = list(surfaces)

    @property
    def n_failed(self) -> int:
        """Rows with an error."""
        return sum(1 for r in self if r.error)

    @property
    def n_flagged(self) -> int:
        """Rows done but flagged (numbers not to be trusted)."""
        return sum(1 for r in self if not r.error and r.flags)

    @property
    def trusted(self) -> bool:
        """Every row done without error or flag."""
        return all(not r.error and not r.flags for r in self)


def worker_context(context: Context, executor) -> Context:
    """The context a batch's task works in (see the module docstring).

    Parameters
    ----------
    context : Context
        The batch's.
    executor : Executor
        Where the batch's tasks run.

    Returns
    -------
    Context
        ``context`` without progress bars where the tasks run in this process; else one
        core (``workers=1``: every finite-element run, surface build and check in the task's
        own process), the same cache folder, no Dask client (a client does not travel).
    """
    if isinstance(executor, InProcess):
        return dataclasses.replace(context, progress=False)
    return Context(cache_dir=context.cache_dir, workers=1, progress=False)


def run_tasks(fn, tasks, context: Context, *, progress: bool | None = None, desc: str = "batch",
              unit: str = "curve"):
    """Run ``fn(worker_context, *args)`` for each ``(tag, args)`` of ``tasks``; yield outcomes as they come.

    Parameters
    ----------
    fn : callable
        A module-level function (workers import it), called with the :func:`worker_context`
        first, then the task's arguments.
    tasks : sequence of (tag, tuple)
    context : Context
        Where the tasks run: ``workers`` local processes (default: the available cores, at most
        one per task; 1 runs them here, one after the other), or the Dask ``client`` or
        ``scheduler``.
    progress : bool or None
        A progress bar over the tasks (none for a single task); None: only on a terminal.
    desc, unit : str
        The bar's label and unit.

    Yields
    ------
    tag, value, error
        ``error`` is None, or the one-line error (:func:`one_line`) of a task that raised or
        whose worker died (``value`` is then None).
    """
    tasks = list(tasks)
    if not tasks:
        return
    executor = make_executor(context.workers, client=context.client, scheduler=context.scheduler,
                             tasks=len(tasks))
    inner = worker_context(context, executor)
    log.info("%s: %d %s%s on %s", desc, len(tasks), unit, "s" if len(tasks) != 1 else "", executor.name)
    bar = progress_bar(progress if len(tasks) >= 2 else False, total=len(tasks), desc=desc, unit=unit)
    try:
        for tag, value, err in executor.imap_unordered(fn, ((tag, (inner, *args)) for tag, args in tasks)):
            yield tag, value, None if err is None else one_line(err)
            bar.update(1)
    finally:
        bar.close()
        executor.close()
