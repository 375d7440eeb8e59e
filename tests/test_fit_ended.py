"""A fit says how it ended: its evaluation budget, its start values, a bound, the edge of its surface.

Each case is a fit of a chosen model (:func:`skin_indent.fitting.fit` with ``model=...``, the
diagnosis's :class:`~skin_indent.fitting.multistart.Fitter`) on an analytic elastic core (the
Hertz-like stand-in of ``analytic_model.py`` in place of a response surface: no finite-element
run), checked in the three outputs a user reads: the text report, the JSON ``flags`` and the
table row (TSV); none of them says "fits to the noise". The ladder never ranks a fit that did not
move, so it can neither name it nor reject a rival with it.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from analytic_model import HertzLikeModel
from skin_indent.fitting import fit, multistart, resume
from skin_indent.fitting.ended import BOUND, BUDGET, EDGE, START, how_it_ended, moved
from skin_indent.measurement import measurement_from_arrays
from skin_indent.response_surface import SurfaceCore

NOISE = 0.01


class _Core(HertzLikeModel, SurfaceCore):
    """The analytic stand-in as an elastic core: a depth range and a name, as a surface has."""

    name = "analytic"

    def __init__(self, radius_mm, lower=(1.0, 0.2), upper=(100.0, 0.49)):
        super().__init__(radius_mm, lower, upper)
        self.depth_range = (0.0, 1.0)


class _FlatCore(_Core):
    """A core whose force no parameter moves: every start is stationary (a fit cannot leave it)."""

    def force(self, depth_mm, theta):
        self._check(theta)
        return super().force(depth_mm, [10.0, 0.45])

    def jacobian(self, depth_mm, theta):
        return np.zeros((np.asarray(depth_mm).size, 2))


@pytest.fixture
def analytic(monkeypatch):
    """Fits of chosen models on the analytic core (``cores["flat"] = True``: the flat one)."""
    cores = {"flat": False}

    def core(effects, *, radius_mm, **_):
        return (_FlatCore if cores["flat"] else _Core)(radius_mm)

    monkeypatch.setattr(multistart, "elastic_core", core)
    return cores


def _curve(E=10.0, nu=0.45, contact_mm=0.0, seed=1):
    d = np.linspace(0.006, 0.6, 100)
    F = _Core(6.22, upper=(1e3, 0.49)).force(np.maximum(d - contact_mm, 0.0), [E, nu])
    F = F + np.random.default_rng(seed).normal(0.0, NOISE, d.size)
    return measurement_from_arrays(d, F, source="analytic.csv", radius_mm=6.22)


def _fit(m, model="neo-hooke", tmp_path=None):
    from skin_indent.runtime.context import Context

    return fit(m, model=model, noise_mN=NOISE, context=Context(cache_dir=tmp_path, progress=False))


def _outputs(result, tmp_path):
    """The text report, the JSON flags and the TSV table of one fit."""
    from skin_indent.batch import _row_of
    from skin_indent.report.batch_table import write_tsv

    text = result.report()
    flags = json.loads(json.dumps(result.to_dict()))["flags"]
    row = _row_of({"file": "analytic.csv"}, result, None)
    table = write_tsv([row], tmp_path / "fits.tsv").read_text()
    return text, flags, table, row


def _said_everywhere(result, tmp_path, words):
    text, flags, table, row = _outputs(result, tmp_path)
    assert any(words in f for f in flags), flags
    assert words in text and "flag: " in text
    assert words in table
    assert "fits to the noise" not in text and row.verdict.startswith("not a result"), row.verdict
    assert not row.trusted


def test_a_fit_stopped_by_its_budget_says_so(analytic, monkeypatch, tmp_path):
    monkeypatch.setattr(multistart, "SURFACE_MAX_EVALUATIONS", 3)
    monkeypatch.setattr(resume, "RESUMES", 0)
    r = _fit(_curve(), tmp_path=tmp_path)
    assert r.status == 0 and not r.success
    _said_everywhere(r, tmp_path, "stopped at its evaluation budget")
    assert "next: " in next(f for f in r.flags if "budget" in f)


def test_a_fit_stopped_by_its_budget_goes_on_from_where_it_got(analytic, monkeypatch, tmp_path):
    """The same budget with restarts from the end (fresh trust region) reaches the fit without a budget."""
    monkeypatch.setattr(multistart, "SURFACE_MAX_EVALUATIONS", 3)
    m = _curve()
    resumed = _fit(m, tmp_path=tmp_path)
    monkeypatch.setattr(multistart, "SURFACE_MAX_EVALUATIONS", None)
    free = _fit(m, tmp_path=tmp_path)
    assert resumed.info.get("resumed", 0) >= 1
    assert resumed.chi2 <= free.chi2 * (1 + 1e-3) or resumed.status == 0  # never claims more than it reached
    if resumed.status == 0:
        assert any("evaluation budget" in f for f in resumed.flags)


def test_a_fit_that_ended_at_its_start_values_says_so(analytic, tmp_path):
    analytic["flat"] = True
    r = _fit(_curve(), tmp_path=tmp_path)
    assert not moved(r)
    _said_everywhere(r, tmp_path, "ended at its start values")


def test_a_parameter_at_a_bound_says_so_and_names_it(analytic, tmp_path):
    # contact 0.4 mm before the first point: the contact point stops at the earliest its range allows
    r = _fit(_curve(contact_mm=-0.4), model="neo-hooke+offset", tmp_path=tmp_path)
    _said_everywhere(r, tmp_path, "offset_mm at the bound of its range")
    assert "--fix offset_mm=VALUE" in " ".join(r.flags)


def test_a_parameter_at_the_edge_of_its_surface_says_so(analytic, tmp_path):
    r = _fit(_curve(E=150.0), tmp_path=tmp_path)  # stiffer than the core's last modulus, 100 kPa
    assert math.isclose(r.parameters["E_kPa"], 100.0)
    _said_everywhere(r, tmp_path, "E_kPa at the bound of its range (E_kPa = 100), the edge of the analytic")


def test_a_fit_inside_its_ranges_has_no_ending_flag(analytic, tmp_path):
    r = _fit(_curve(), tmp_path=tmp_path)
    assert r.success and not [f for f in r.flags if "not a result" in f]
    assert r.quality["verdict"] in ("fits to the noise", "fits below the noise level")


def test_how_it_ended_names_what_results_report(analytic, tmp_path):
    """The kinds, and the reported name of a fit coordinate (a layer's compliance is its ratio)."""
    from skin_indent.fitting.ended import reported_name
    from skin_indent.fitting.model_fit import prepare_curve
    from skin_indent.models import ComposedModel

    m = prepare_curve(_curve())
    layer = ComposedModel(_LayerCore(6.22), ("layer",), m)
    x = np.array([10.0, 0.45, 1.2, 0.25])
    assert reported_name(layer, x, "compliance") == ("ratio", 4.0)
    assert reported_name(layer, x, "thickness_mm") == ("thickness_mm", 1.2)
    r = _fit(_curve(E=150.0), tmp_path=tmp_path)
    kinds = [e.kind for e in how_it_ended(r)]
    assert kinds and set(kinds) <= {BUDGET, START, EDGE, BOUND}


class _LayerCore(_Core):
    """A core with a layer's fit coordinates (the force ignores them): names only."""

    parameter_names = ("E_kPa", "nu", "thickness_mm", "compliance")

    def __init__(self, radius_mm):
        super().__init__(radius_mm)
        self.bounds = (np.array([1.0, 0.2, 0.7, 0.0]), np.array([100.0, 0.49, 10.0, 8.0]))


# ----------------------------------------------------------------------------- the ladder
@dataclasses.dataclass(frozen=True)
class _Rung:
    effects: tuple
    chi2_weighted: float
    n_parameters: int
    moved: bool = True
    aic: float = math.nan
    bic: float = math.nan
    n_eff: float = math.nan

    @property
    def model(self):
        return "neo-hooke" + "".join(f"+{e}" for e in self.effects)


class _Fitter:
    """What :func:`~skin_indent.diagnosis.workflow._examine` asks of a fitter, with given fits."""

    def __init__(self, fits):
        self.fits = fits

    def fit(self, key):
        return self.fits[tuple(key)]

    def fit_all(self, keys):
        return {tuple(k): self.fits[tuple(k)] for k in keys}

    def visible(self, e):
        return None


def test_the_ladder_never_ranks_nor_rejects_with_a_fit_that_did_not_move():
    from skin_indent.diagnosis.criteria import NOT_FITTED, Scores, unmoved
    from skin_indent.diagnosis.workflow import _examine

    n = 100
    fits = {("layer",): _Rung(("layer",), 400.0, 4),
            ("layer", "layer"): _Rung(("layer", "layer"), 100.0, 6),
            # ended exactly where it started (the layer rung's values): worse than the layer rung
            ("layer", "stiffening"): _Rung(("layer", "stiffening"), 401.0, 5, moved=False)}
    step = _examine(_Fitter(fits), ("layer",), ("layer", "stiffening"), Scores(n, n))
    assert [f.effects for f in step.ranking] == [("layer", "layer")]
    assert step.not_detectable["stiffening"].startswith(NOT_FITTED)
    assert "ended at its start values" in step.not_detectable["stiffening"]
    assert unmoved(fits["layer", "layer"]) is None
    # the same fit having moved is ranked (and then it is a rival the BIC may exclude)
    fits["layer", "stiffening"] = dataclasses.replace(fits["layer", "stiffening"], moved=True)
    step = _examine(_Fitter(fits), ("layer",), ("layer", "stiffening"), Scores(n, n))
    assert {f.effects[-1] for f in step.ranking} == {"layer", "stiffening"}


def test_a_start_the_data_push_against_a_face_is_an_optimum_not_a_stall():
    """Not moving from a start on a face of the range that the data push against (an effect switched
    off at its bound) is an optimum the fit found; not moving from a flat start is a stall."""
    from skin_indent.fitting.ended import stalled
    from skin_indent.inverse import fit_least_squares

    d = np.linspace(0.006, 0.6, 60)
    F = _Core(6.22, upper=(1e3, 0.49)).force(d, [150.0, 0.49])
    at_face = fit_least_squares(_Core(6.22), d, F, [100.0, 0.49], noise_mN=NOISE)
    assert not moved(at_face) and at_face.status > 0 and not stalled(at_face)
    flat = fit_least_squares(_FlatCore(6.22), d, F, [20.0, 0.4], noise_mN=NOISE)
    assert not moved(flat) and stalled(flat)
    assert [e.kind for e in how_it_ended(flat)] == [START]


# ----------------------------------------------------------------------------- the final model
def test_the_final_model_gives_the_modulus_of_each_body_and_what_ratio_means():
    """Two layers over a half-space: E of each body is E times the ratios above it (the bundled
    forearm-like curve's truth: 17.54, 2.92 and 9.35 kPa under 1 and 3 mm)."""
    from types import SimpleNamespace

    from skin_indent.fitting.bodies import RATIOS_MEANING, bodies, body_lines
    from skin_indent.measurement.scale import SKIN_UNITS

    p = {"E_kPa": 17.54, "nu": 0.48, "thickness_mm": 1.0, "ratio": 2.92 / 17.54, "thickness2_mm": 3.0,
         "ratio2": 9.35 / 2.92}
    rung = SimpleNamespace(parameters=p, std={"E_kPa": 0.5, "thickness2_mm": 0.4, "ratio": 0.02, "ratio2": 0.5},
                           effects=("layer", "layer"), model="neo-hooke+layer+layer",
                           reported_cov=(("E_kPa", "ratio", "ratio2"), np.diag([0.5**2, 0.02**2, 0.5**2])))
    b = bodies(rung)
    assert [round(x["E_kPa"], 6) for x in b["bodies"]] == [17.54, 2.92, 9.35]
    assert [x["thickness_mm"] for x in b["bodies"]] == [1.0, 3.0, None]
    assert b["ratio"] == RATIOS_MEANING and b["other"] == {}
    lines = body_lines(rung, SKIN_UNITS)
    assert lines[1].startswith("  top layer: E = 17.54 +- 0.5 kPa, thickness = 1 mm (held)")
    # E x ratio, independent errors: sqrt((ratio sd_E)^2 + (E sd_ratio)^2) = 0.36 kPa
    assert "layer 2: E = 2.92 +- 0.36 kPa, thickness = 3 +- 0.4 mm" in lines[2]
    assert "below: half-space: E = 9.35" in lines[3]
    assert "ratio = E of the material below a layer / E of the layer" in lines[-1]
    rigid = SimpleNamespace(**{**vars(rung), "parameters": {**p, "ratio2": math.inf}})
    assert body_lines(rigid, SKIN_UNITS)[3] == "  below: rigid base: E = inf (rigid)"


def test_the_cli_says_why_a_fit_is_not_a_result_and_what_to_do(analytic, monkeypatch, tmp_path, capsys):
    """``skin-indent fit --model``: exit 3, stderr with the reason and the next step, JSON ``flags``."""
    from skin_indent.cli import main
    from skin_indent.measurement import save_csv

    monkeypatch.setenv("SKIN_INDENT_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(multistart, "SURFACE_MAX_EVALUATIONS", 3)
    monkeypatch.setattr(resume, "RESUMES", 0)
    path = tmp_path / "analytic.csv"
    save_csv(_curve(), path)
    code = main(["fit", str(path), "--model", "neo-hooke", "--radius", "6.22", "--noise", str(NOISE), "--json"])
    out, err = capsys.readouterr()
    assert code == 3
    d = json.loads(out)
    assert d["success"] is False and any("evaluation budget" in f for f in d["flags"])
    assert "the fit did not converge" in err and "next: " in err and "evaluation budget" in err
    code = main(["fit", str(path), "--model", "neo-hooke", "--radius", "6.22", "--noise", str(NOISE)])
    out, _ = capsys.readouterr()
    assert code == 3 and "fits to the noise" not in out and "quality: not a result" in out


def test_an_effect_switched_off_at_the_end_of_its_range_is_an_answer_not_a_flag(analytic, tmp_path):
    """Adhesion on a curve without it: w ends at 0, the end of its range that switches it off (C20 = 0 of
    stiffening alike); the same fit with w at a bound elsewhere would be flagged."""
    from skin_indent.fitting.model_fit import prepare_curve
    from skin_indent.models import ComposedModel

    m = prepare_curve(_curve())
    model = ComposedModel(_Core(6.22), ("adhesion",), m)
    x = np.array([10.0, 0.45, 0.0])
    assert model.parameter_names == ("E_kPa", "nu", "w_mJ_per_m2")
    result = dataclasses.make_dataclass("R", ["status", "info", "free_names", "parameters", "message",
                                              "iterations"])(
        1, {"active_bounds": ["w_mJ_per_m2"], "x0": {}}, tuple(model.parameter_names),
        dict(zip(model.parameter_names, x)), "converged", 3)
    assert how_it_ended(result, model, x) == []


def test_a_fit_stopped_by_its_budget_resumed_from_its_end_reaches_the_unbudgeted_fit(monkeypatch):
    """Restarts with a fresh trust region and the same small budget end where one long fit ends."""
    from skin_indent.fitting.resume import cost, resumed
    from skin_indent.inverse import fit_least_squares

    d = np.linspace(0.006, 0.6, 60)
    core = _Core(6.22)
    F = core.force(d, [12.0, 0.42]) + np.random.default_rng(3).normal(0.0, NOISE, d.size)
    short = fit_least_squares(core, d, F, [40.0, 0.3], noise_mN=NOISE, max_nfev=3)
    assert short.status == 0
    monkeypatch.setattr(resume, "RESUMES", 50)
    on = resumed(core, d, F, short, noise_mN=NOISE, known={}, options={"max_nfev": 3})
    full = fit_least_squares(core, d, F, [40.0, 0.3], noise_mN=NOISE)
    assert on.status > 0 and on.info["resumed"] >= 1
    assert on.info["x0"] == short.info["x0"] and on.info["nfev"] > short.info["nfev"]
    assert cost(on) <= cost(full) * (1 + 1e-6)
    for name in ("E_kPa", "nu"):
        assert abs(on.parameters[name] - full.parameters[name]) < 1e-3 * full.std[name]


def test_a_fit_at_a_physical_limit_says_it_is_a_limit_not_a_value(analytic):
    """nu at the nearly incompressible end of the fitted range: not a flag (the data may rightly reach it),
    but a note that the value is a bound; a rigid base alike; nothing for a fit inside its ranges."""
    from types import SimpleNamespace

    from skin_indent.fitting.ended import limit_notes
    from skin_indent.fitting.model_fit import prepare_curve
    from skin_indent.models import ComposedModel

    m = prepare_curve(_curve())
    model = ComposedModel(_Core(6.22), (), m)
    top = float(model.bounds[1][list(model.parameter_names).index("nu")])
    x = np.array([5.0, top])

    def result(at):
        return SimpleNamespace(info={"active_bounds": at}, free_names=("E_kPa", "nu"),
                               parameters=dict(zip(model.parameter_names, x)))

    notes = limit_notes(result(("nu",)), model, x)
    assert len(notes) == 1 and "nu = " in notes[0] and "nearly incompressible" in notes[0] and "bound" in notes[0]
    assert limit_notes(result(()), model, x) == []
    layer = ComposedModel(_LayerCore(6.22), ("layer",), m)
    rigid = np.array([10.0, 0.45, 1.2, 0.0])  # compliance 0: a rigid base
    at_rigid = SimpleNamespace(info={"active_bounds": ("compliance",)}, free_names=layer.parameter_names,
                               parameters=dict(zip(layer.parameter_names, rigid)))
    notes = limit_notes(at_rigid, layer, rigid)
    assert len(notes) == 1 and notes[0].startswith("ratio") and "rigid base" in notes[0]


def test_the_final_model_says_a_rigid_base_reached_by_the_fit_is_a_bound(analytic):
    """The final model that diagnose, the demo and the report print (fitting.bodies) carries the same
    sentence as fit's notes where a parameter ended at a physical limit: a rigid base reached by the fit
    is a bound, not a measured modulus."""
    from types import SimpleNamespace

    from skin_indent.fitting.bodies import bodies, body_lines
    from skin_indent.fitting.model_fit import prepare_curve
    from skin_indent.measurement.scale import display_units
    from skin_indent.models import ComposedModel

    layer = ComposedModel(_LayerCore(6.22), ("layer",), prepare_curve(_curve()))
    rigid = np.array([10.0, 0.45, 1.2, 0.0])  # compliance 0: a rigid base

    def rung(at):
        reported = dict(layer.model_parameters(rigid))
        return SimpleNamespace(info={"active_bounds": at}, free_names=layer.parameter_names, effects=("layer",),
                               model="neo-hooke+layer", parameters=reported, std={"E_kPa": 1.0, "nu": 0.02,
                                                                                  "thickness_mm": 0.1},
                               reported_cov=((), np.zeros((0, 0))), bound_model=layer, x=rigid)

    b = bodies(rung(("compliance",)))
    assert b["bodies"][-1]["body"] == "below: rigid base"
    assert len(b["limits"]) == 1 and "rigid base" in b["limits"][0] and "bound" in b["limits"][0]
    lines = body_lines(rung(("compliance",)), display_units(6.22))
    assert any(line.startswith("  note: ratio") and "not a measured value" in line for line in lines)
    assert "limits" not in bodies(rung(()))  # held there by the user, not reached by the fit: no note
