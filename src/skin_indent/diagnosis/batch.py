"""Many diagnoses at a time: every curve of files, folders and force maps, one row each.

:func:`diagnose_many` reads every curve (all curves of a force map, or one ``index``:
:mod:`skin_indent.measurement.curve_files`), prepares each one here as :func:`diagnose` prepares
it (so that a curve that cannot be prepared is a row with its error before any work), then
diagnoses the curves on the local cores or a Dask cluster through the machinery of the batches of
fits (:func:`skin_indent.runtime.batch.run_tasks`): each curve is :func:`diagnose` itself, called
with the batch's settings on the prepared curve, so its verdict is the one :func:`diagnose` gives
that curve alone. A diagnosis in a worker process runs its finite-element work in that process
(one core: no process pool inside a worker); the surfaces and runs it needs go to the batch's
cache folder, which every curve shares. A file that cannot be read, or a curve that cannot be
diagnosed, is one :class:`DiagnosisRow` with its one-line ``error``: never the end of the batch.

The rows hold the verdict, the final model with its parameters and standard deviations, the
misfit and the whiteness of its residual; :func:`skin_indent.report.batch_table.write_tsv` writes
them as a table with a provenance header, :mod:`skin_indent.report.verdict_map` draws the verdict,
misfit and modulus per curve and over each force map.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import os
from dataclasses import dataclass, field, fields

from ..effects import EFFECTS, WEIGHED, effect, instances
from ..fitting.bodies import limits
from ..fitting.model_fit import prepare_curve
from ..measurement import SEGMENTS
from ..measurement.scale import PACKAGE_UNITS
from ..measurement.curve_files import CurveLocation, expand_paths, read_curves
from ..runtime.batch import BatchRows, one_line, run_tasks
from ..runtime.context import context_of
from ..runtime.json_io import jsonable
from ..runtime.provenance import provenance as make_provenance
from .knowns import check_known
from .workflow import diagnose

__all__ = ["DIAGNOSIS_COLUMNS", "FAILED", "DiagnosisBatch", "DiagnosisRow", "diagnose_many", "portable"]

log = logging.getLogger(__name__)

#: the outcome of a curve that could not be read, prepared or diagnosed (:attr:`DiagnosisRow.outcome`)
FAILED = "failed"


@dataclass(frozen=True)
class DiagnosisRow(CurveLocation):
    """The diagnosis of one curve of a batch (or the error of a curve or file that gave none).

    The numbers are those of the :class:`~skin_indent.diagnosis.Diagnosis` of the curve
    (``to_dict()`` of ``skin-indent diagnose --json``): one set per model.

    Attributes
    ----------
    file, index, grid_x, grid_y, x_mm, y_mm
        Where the curve comes from (:class:`~skin_indent.measurement.curve_files.CurveLocation`).
    radius_mm : float
        Sphere radius (mm).
    n_points : int
        Points diagnosed (after binning).
    noise_mN : float
        Noise level of the prepared points (mN): given, or estimated from the data.
    verdict : str
        What the given model misses: an effect (``"layer"``), several (``"offset+layer"``),
        ``"none"``, ``"unexplained"`` or ``"ambiguous"`` (:attr:`Diagnosis.verdict`).
    sample : str
        The sample's verdict (the same as ``verdict``: the instrument's effects are never in it).
    instrument : str
        The instrument's effects named (``"drag, baselines"``) or ``"none"``
        (:attr:`Diagnosis.instrument_verdict`).
    segments : str
        What the final model leaves on each segment, in words (:meth:`Diagnosis.segments_sentence`,
        package units).
    provisional : bool or None
        Combinations were left untried (``untried``): the verdict holds for what was fitted.
    explained : bool or None
        The final model explains the curve to the noise (white residual, RMS at the noise).
    model : str
        The final model (the last rung of the ladder), e.g. ``neo-hooke+layer``.
    E_kPa, E_std_kPa : float
        Its main modulus (kPa; the top layer's for a layered model) and standard deviation.
    rms_mN : float
        RMS residual of the final model (mN).
    misfit : float
        RMS / noise of the final model.
    white : bool or None
        The final model's residual is white.
    base_rms_mN : float
        RMS residual of the given model (the first rung: the half-space by default), mN.
    confounded_with : tuple of str
        The explanations the data do not exclude (the chosen one first), empty when none.
    untried : tuple of str
        The combinations of effects not fitted (why: in the diagnosis' ``untried_reasons``).
    undetermined : tuple of str
        Parameters of the final model the curve does not determine.
    error : str
        One-line error when the file or the curve could not be read, prepared or
        diagnosed (the numbers are then NaN): too few points to estimate the noise, or fewer
        points in contact than the given model's parameters need (``"c.csv: 3 point(s) in
        contact for 2 fitted parameter(s) of neo-hooke, at least 4 needed: ..."``); empty
        otherwise.
    flags : tuple of str
        What makes the diagnosis doubtful (the diagnosis' ``notes``: fewer points in contact
        than five per parameter of the final model) or went wrong around it (an output not
        written); empty normally.
    parameters, std : dict
        The final model's parameters and standard deviations (the table gets ``NAME`` and
        ``NAME_sd`` for each beyond ``E_kPa``).
    diagnosis : Diagnosis or None
        The whole diagnosis (:func:`portable`), kept only when asked for
        (``diagnose_many(..., keep_diagnoses=True)``) or while ``on_row`` sees the row.
    """

    radius_mm: float = math.nan
    n_points: int = 0
    noise_mN: float = math.nan
    verdict: str = ""
    sample: str = ""
    instrument: str = ""
    segments: str = ""
    provisional: bool | None = None
    explained: bool | None = None
    model: str = ""
    E_kPa: float = math.nan
    E_std_kPa: float = math.nan
    rms_mN: float = math.nan
    misfit: float = math.nan
    white: bool | None = None
    base_rms_mN: float = math.nan
    confounded_with: tuple = ()
    untried: tuple = ()
    undetermined: tuple = ()
    error: str = ""
    flags: tuple = ()
    parameters: dict = field(default_factory=dict, compare=False)
    std: dict = field(default_factory=dict, compare=False)
    diagnosis: object = field(default=None, repr=False, compare=False)

    #: parameters with a column of their own (the table gets ``NAME`` and ``NAME_sd`` for the others)
    own_parameters = ("E_kPa",)

    @property
    def trusted(self) -> bool:
        """Diagnosed, and nothing went wrong around it."""
        return not self.error and not self.flags

    @property
    def outcome(self) -> str:
        """What a table of verdicts or a map shows for the curve: its verdict, or :data:`FAILED`."""
        return FAILED if self.error else self.verdict

    def to_dict(self) -> dict:
        """The row as a JSON-safe dict (without ``diagnosis``)."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "diagnosis"}
        for name in ("confounded_with", "untried", "undetermined", "flags"):
            out[name] = list(out[name])
        out["parameters"], out["std"] = dict(self.parameters), dict(self.std)
        return jsonable(out)


#: the columns of the table of a batch of diagnoses, in order (then ``NAME``, ``NAME_sd`` for each
#: parameter of the final models beyond E_kPa)
DIAGNOSIS_COLUMNS = tuple(f.name for f in fields(DiagnosisRow) if f.name not in ("diagnosis", "parameters", "std"))


class DiagnosisBatch(BatchRows):
    """The rows of :func:`diagnose_many` (a list of :class:`DiagnosisRow`, in file and curve order).

    Attributes
    ----------
    provenance : dict
        How they were made: the inputs with their sha256, the settings of every diagnosis,
        the command line or the API call.
    """

    #: the columns of :func:`~skin_indent.report.batch_table.write_tsv`
    columns = DIAGNOSIS_COLUMNS

    def verdicts(self) -> dict:
        """``{outcome: number of curves}``: each verdict, and :data:`FAILED` for the curves not diagnosed;
        most frequent first."""
        counts: dict = {}
        for r in self:
            counts[r.outcome] = counts.get(r.outcome, 0) + 1
        return dict(sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))


def portable(diagnosis):
    """The diagnosis without what ties it to the process that made it, to send it back from a worker.

    Every rung keeps its numbers, predictions and residual analysis; the fitted force models
    (``bound_model``: surfaces, finite-element cores) are left out (about 25
    kB instead of MBs); where a parameter ended at a physical limit, the sentence that needs the model
    is kept in ``info["limits"]`` (:func:`~skin_indent.fitting.bodies.limits`). Its text, sentence, JSON and HTML report are those of the whole one.
    """
    light: dict = {}

    def rung(r):
        if id(r) not in light:  # what needs the model is said before it goes (fitting.bodies reads it)
            light[id(r)] = dataclasses.replace(r, bound_model=None, info={**(r.info or {}), "limits": limits(r)})
        return light[id(r)]

    return dataclasses.replace(
        diagnosis, ladder=[rung(r) for r in diagnosis.ladder],
        ranking=[rung(r) for r in diagnosis.ranking], alternatives=[rung(r) for r in diagnosis.alternatives],
        steps=[dataclasses.replace(s, rung=rung(s.rung), ranking=[rung(r) for r in s.ranking],
                                   rivals=[rung(r) for r in s.rivals]) for s in diagnosis.steps],
        instrument_steps=[dataclasses.replace(s, rung=rung(s.rung), ranking=[rung(r) for r in s.ranking])
                          for s in diagnosis.instrument_steps])


def _numbers(d) -> dict:
    """The fields of a :class:`DiagnosisRow` from a diagnosis."""
    cur = d.current
    return {"radius_mm": float(d.radius_mm), "n_points": int(d.data.n), "noise_mN": float(d.noise_mN),
            "verdict": d.verdict, "sample": d.verdict, "instrument": d.instrument_verdict,
            "segments": str(d.segments_sentence(PACKAGE_UNITS)),
            "provisional": bool(d.provisional), "explained": bool(d.explained),
            "model": cur.model, "E_kPa": float(cur.parameters.get("E_kPa", math.nan)),
            "E_std_kPa": float(cur.std.get("E_kPa", math.nan)), "rms_mN": float(cur.rms_mN),
            "misfit": float(cur.rms_mN / d.noise_mN), "white": bool(cur.white), "base_rms_mN": float(d.base.rms_mN),
            "confounded_with": tuple(d.confounded_with), "untried": tuple(d.untried),
            "undetermined": tuple(d.not_determined), "parameters": dict(cur.parameters), "std": dict(cur.std),
            "flags": tuple(str(n) for n in d.notes) + tuple(str(f) for f in cur.flags)}  # + how its fit ended


@contextlib.contextmanager
def _quiet(on: bool):
    """The package's INFO lines off in the block (a worker's: many diagnoses at once would mix them)."""
    logger = logging.getLogger("skin_indent")
    old = logger.level
    if on:
        logger.setLevel(max(old, logging.WARNING))
    try:
        yield
    finally:
        logger.setLevel(old)


def _diagnose_task(context, prepared, settings: dict, keep: bool, parent: int, details: bool):
    """One diagnosis in a worker (:func:`~skin_indent.runtime.batch.run_tasks`): ``(fields, portable
    diagnosis or None)``, or ``(None, one-line error)`` (nothing raised). Its INFO lines are kept only
    in the batch's own process (``parent``) or with ``details``."""
    try:
        with _quiet(os.getpid() != parent and not details):
            d = diagnose(prepared, context=context, **settings)
    except Exception as err:  # noqa: BLE001 - one row with the error, never the end of the batch
        return None, one_line(err)
    return _numbers(d), (portable(d) if keep else None)


def _check(candidates, add, max_rungs) -> None:
    """The settings' errors in one line each, before any file is read (as :func:`diagnose` would raise them)."""
    for name in (*(candidates or ()), *add):
        effect(name)  # one line naming the vocabulary for an unknown name
    instances(tuple(effect(a).name for a in add))  # an effect given twice that cannot repeat
    for name in add:
        if effect(name).stage == WEIGHED:
            raise ValueError(f"add {name}: it is weighed, not fitted; no fitted model has it yet")
    if isinstance(max_rungs, bool) or not isinstance(max_rungs, int) or max_rungs < 0:
        raise ValueError(f"max_rungs must be an integer >= 0, got {max_rungs!r}")


def diagnose_many(paths, *, index: int | None = None, radius_mm: float | None = None, candidates=None, add=(),
                  noise_mN: float | None = None, segments=SEGMENTS, max_rungs: int = 3, in_loop: bool = True,
                  mesh: str = "coarse", context=None, progress: bool | None = None, keep_diagnoses: bool = False,
                  on_row=None, recursive: bool = False, command=None, fixed: dict | None = None,
                  priors: dict | None = None, free=()) -> DiagnosisBatch:
    """Diagnose every curve of every file, in parallel; one :class:`DiagnosisRow` per curve.

    Parameters
    ----------
    paths : path or iterable of paths
        Files and folders (:func:`~skin_indent.measurement.curve_files.expand_paths`): CSV, Chiaro
        ``.txt`` and, with afmformats, JPK ``.jpk-force``/``.jpk-force-map``, HDF5 and the other
        instrument formats (:func:`skin_indent.measurement.load_curves`).
    index : int, optional
        Diagnose only this curve of each file (from 0); default every curve (all curves of a
        force map).
    radius_mm : float, optional
        Sphere radius (mm) of every curve; default each file's own, else the skin default 6.22 mm.
    candidates, add, noise_mN, segments, max_rungs, in_loop, mesh
        As :func:`~skin_indent.diagnosis.diagnose`, for every curve (``noise_mN``: the noise of
        a raw sample of every curve; default each curve's own, estimated from its data).
    context : Context, optional
        Cache folder, shared by every curve, and where the curves are diagnosed: ``workers``
        local processes (default: the available cores, at most one per curve; 1 diagnoses them
        here one after the other), or the Dask ``client`` or ``scheduler``. A curve diagnosed in
        a worker makes its finite-element runs in that worker, on one core; a batch of one curve,
        or ``workers=1``, diagnoses here with the context as a single :func:`diagnose` would.
    progress : bool or None
        A progress bar over the curves (tqdm, on stderr); default only on a terminal.
    keep_diagnoses : bool
        Keep each curve's :class:`~skin_indent.diagnosis.Diagnosis` in its row (``row.diagnosis``,
        made :func:`portable`): its text, JSON and HTML report.
    on_row : callable, optional
        ``on_row(row, provenance)``, called here as each curve's diagnosis arrives, with
        ``row.diagnosis`` set and the batch's provenance (e.g. to write the curve's report while
        the others are diagnosed: :func:`skin_indent.report.verdict_map.write_curve_report`); it
        may return a row to keep instead (with a flag, say), else the row is kept as it is.
    recursive : bool
        Search folders' subfolders too.
    fixed, priors : dict, optional
        What is known of every sample, held or weighed in every model that has the parameter
        (as :func:`~skin_indent.diagnosis.diagnose`).
    free : sequence of str
        ``("nu",)``: fit nu at AFM scale, where every curve's models hold it otherwise (as
        :func:`~skin_indent.diagnosis.diagnose`).
    command : sequence of str, optional
        The command line to record; default: the API call (``skin_indent.diagnose_many``).

    Returns
    -------
    DiagnosisBatch
        A list of :class:`DiagnosisRow` in file and curve order, with ``provenance``.

    Raises
    ------
    ValueError
        A setting that no curve could take (an unknown effect, ``max_rungs`` < 0), before any
        file is read. Bad files and curves are rows.

    Examples
    --------
    >>> from skin_indent.runtime.context import Context
    >>> rows = diagnose_many("curves/", in_loop=False, context=Context(workers=2))  # doctest: +SKIP
    >>> rows.verdicts()                                                          # doctest: +SKIP
    {'none': 5, 'layer': 3}
    """
    add = tuple(add)
    _check(candidates, add, max_rungs)
    check_known(fixed, priors, (*(EFFECTS if candidates is None else candidates), *add), 1)
    ctx = context_of(context)
    files = expand_paths(paths, recursive=recursive)
    segments = tuple(segments)
    settings = {"candidates": None if candidates is None else tuple(candidates), "add": add, "noise_mN": noise_mN,
                "segments": segments, "max_rungs": max_rungs, "in_loop": in_loop, "mesh": mesh, "radius_mm": radius_mm}
    if fixed:
        settings["fixed"] = dict(fixed)
    if priors:
        settings["priors"] = {k: tuple(v) for k, v in priors.items()}
    if free:
        if set(free) - {"nu"}:
            raise ValueError(f"free takes nu, got {', '.join(free)}")
        settings["free"] = tuple(free)
    rows: list = []  # DiagnosisRow, or (location keywords, prepared curve) waiting for its diagnosis
    for where, m, error in read_curves(files, index=index, radius_mm=radius_mm):
        if error is None:
            try:
                rows.append((where.location, prepare_curve(m, radius_mm=radius_mm, segments=segments)))
                continue
            except Exception as err:  # noqa: BLE001 - a curve that cannot be prepared is one row
                error = one_line(err)
        rows.append(DiagnosisRow(**where.location, error=error))
    pending = [i for i, r in enumerate(rows) if isinstance(r, tuple)]
    log.info("%d curve%s read from %d file%s (%d could not be read or prepared)", len(rows),
             "s" if len(rows) != 1 else "", len(files), "s" if len(files) != 1 else "", len(rows) - len(pending))
    prov = make_provenance(command=command, inputs=files, settings={**settings, "index": index},
                           api=None if command is not None else "skin_indent.diagnose_many")

    keep = keep_diagnoses or on_row is not None
    details = logging.getLogger("skin_indent").isEnabledFor(logging.DEBUG)
    tasks = [(i, (rows[i][1], settings, keep, os.getpid(), details)) for i in pending]
    for i, value, err in run_tasks(_diagnose_task, tasks, ctx, progress=progress, desc="diagnosing"):
        where, prepared = rows[i]
        numbers, extra = value if err is None else (None, err)
        if numbers is None:
            rows[i] = DiagnosisRow(**where, radius_mm=prepared.radius_mm, n_points=int(prepared.n), error=extra)
            continue
        row = DiagnosisRow(**where, **numbers, diagnosis=extra)
        if on_row is not None:
            row = on_row(row, prov) or row
        rows[i] = row if keep_diagnoses else dataclasses.replace(row, diagnosis=None)
    return DiagnosisBatch(rows, provenance=prov)
