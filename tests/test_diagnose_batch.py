"""Many diagnoses at a time (skin_indent.diagnosis.diagnose_many, ``skin-indent diagnose`` of several curves).

- The visible hidden-effect curves (tests/data/hidden-effects) and a bad file, diagnosed in one
  batch on 2 local processes: every row is the diagnosis of that curve alone (verdict, final
  model, every number, the whole diagnosis' JSON), the bad file a row with its one-line error.
- A small synthetic force map (curves of the forward model with and without a contact offset and
  with strain stiffening, and one noise-free curve that cannot be diagnosed, written as one HDF5
  file of afmformats): one row per pixel equal to the diagnosis of that curve alone, a map
  figure of the verdicts; a Dask LocalCluster (2 worker processes) gives the same table as local
  processes.
- The command line: the batch's lines, table and figures, exit statuses, one-line user errors.

Cheap settings throughout (surfaces only, one rung, coarse mesh, few candidates on the map): the
surfaces come from the gallery cache that conftest.py's ``diagnosis_surfaces`` fills once per run.
"""

from __future__ import annotations

import csv
import json
import math
import os

import numpy as np
import pytest
from _data import DATA

from skin_indent.data import bundled_path
from skin_indent.diagnosis import DiagnosisRow, diagnose, diagnose_many
from skin_indent.diagnosis.batch import DIAGNOSIS_COLUMNS, FAILED
from skin_indent.measurement import load_csv, load_curve
from skin_indent.report.batch_table import write_tsv
from skin_indent.report.verdict_map import force_maps, map_figure, verdict_colours, verdict_line, write_batch_figures
from skin_indent.runtime.batch import worker_context
from skin_indent.runtime.context import Context
from skin_indent.runtime.executors import InProcess, LocalProcesses
from skin_indent.runtime.json_io import dumps
from skin_indent.runtime.provenance import read_provenance

HIDDEN = DATA / "hidden-effects"
#: the answer key of tests/data/hidden-effects/README.md
KEY = {"v01_clean": "none", "v02_layer_soft_base": "layer", "v03_layer_rigid_base": "layer",
       "v04_stiffening": "stiffening", "v05_offset": "offset", "v06_viscoelastic": "viscoelastic"}
#: the settings of every diagnosis of the hidden-effect curves here (cheap: one rung, surfaces only)
CHEAP = {"max_rungs": 1, "in_loop": False, "mesh": "coarse"}
#: the map's: two candidates (each diagnosis about a second)
MAP_SETTINGS = {**CHEAP, "candidates": ("offset", "stiffening")}
R_MM = 6.22
MAP_GROUP = pytest.mark.xdist_group("diagnose-batch-map")


def _json(obj) -> dict:
    out = json.loads(dumps(obj))
    out.pop("provenance", None)
    return out


def _bad_file(folder):
    bad = folder / "broken.csv"
    bad.write_text("time_s,depth_mm,force_mN\n0,0,0\n1,oops,1\n")
    return bad


# ------------------------------------------------------------------ the visible hidden-effect curves
def test_batch_equals_each_curve_diagnosed_alone(gallery_cache, diagnosis_surfaces, tmp_path):
    files = [HIDDEN / f"{name}.csv" for name in KEY]
    bad = _bad_file(tmp_path)
    rows = diagnose_many([*files, bad], context=Context(cache_dir=gallery_cache, workers=2), keep_diagnoses=True,
                         progress=False, **CHEAP)
    assert [r.label for r in rows] == [f"{name}.csv[0]" for name in KEY] + ["broken.csv"]
    assert rows.n_failed == 1 and not rows.trusted
    assert rows[-1].error.startswith("broken.csv: line 3") and "\n" not in rows[-1].error
    assert math.isnan(rows[-1].E_kPa) and rows[-1].verdict == "" and rows[-1].outcome == FAILED
    for name, path, row in zip(KEY, files, rows):
        alone = diagnose(load_csv(path), context=Context(cache_dir=gallery_cache, workers=2), **CHEAP)
        assert row.verdict == alone.verdict == KEY[name], (name, row.verdict, alone.verdict)
        cur = alone.current
        assert (row.model, row.provisional, row.explained, row.white) == (cur.model, alone.provisional,
                                                                          alone.explained, cur.white)
        assert row.E_kPa == cur.parameters["E_kPa"] and row.E_std_kPa == cur.std["E_kPa"]
        assert row.parameters == cur.parameters and row.std == cur.std
        assert row.rms_mN == cur.rms_mN and row.misfit == cur.rms_mN / alone.noise_mN
        assert row.base_rms_mN == alone.base.rms_mN and row.noise_mN == alone.noise_mN
        assert row.untried == tuple(alone.untried) and row.confounded_with == tuple(alone.confounded_with)
        assert _json(row.diagnosis.to_dict()) == _json(alone.to_dict())  # the whole diagnosis, every number
        assert row.diagnosis.report() == alone.report()
    assert rows.verdicts() == {"layer": 2, FAILED: 1, "none": 1, "offset": 1, "stiffening": 1, "viscoelastic": 1}

    # the table: a provenance header, one line per curve, every parameter of the final models with its sd
    path = write_tsv(rows, tmp_path / "verdicts.tsv")
    prov = read_provenance(path)
    assert prov == rows.provenance and prov["api"] == "skin_indent.diagnose_many"
    assert prov["settings"]["max_rungs"] == 1 and prov["settings"]["in_loop"] is False
    assert len(prov["inputs"]) == 7 and all("sha256" in i for i in prov["inputs"])
    with open(path) as fh:
        table = list(csv.DictReader((line for line in fh if not line.startswith("#")), delimiter="\t"))
    assert list(table[0])[:len(DIAGNOSIS_COLUMNS)] == list(DIAGNOSIS_COLUMNS)
    assert {"nu", "nu_sd", "thickness_mm", "ratio_sd", "offset_mm", "C20_kPa", "g1_sd"} <= set(table[0])
    for line, row in zip(table, rows):
        assert line["verdict"] == row.verdict and line["error"] == row.error
        if not row.error:
            assert float(line["E_kPa"]) == pytest.approx(row.E_kPa, rel=1e-9)
            assert float(line["nu_sd"]) == pytest.approx(row.std["nu"], rel=1e-9)
            assert line["provisional"] == str(row.provisional).lower()


# ------------------------------------------------------------------ a force map
@pytest.fixture(scope="module")
def force_map(tmp_path_factory):
    """A 3 x 2 map: two clean curves, two with the contact past the first sample, a stiffening one
    (C20 = 12 kPa), and a pixel where the sphere touched nothing (zero force: not diagnosed)."""
    pytest.importorskip("afmformats")
    pytest.importorskip("h5py")
    from _maps import forward_curve, write_force_map

    path = tmp_path_factory.mktemp("map") / "map.h5"
    curves = [forward_curve(8.0, seed=1), forward_curve(4.0, seed=2), forward_curve(6.0, contact_mm=0.02, seed=3),
              forward_curve(10.0, contact_mm=0.03, seed=4), forward_curve(6.0, C20_kPa=12.0, seed=5),
              (np.linspace(0.0, 0.6, 100), np.zeros(100), np.linspace(0.0, 30.0, 100))]
    write_force_map(path, curves, nx=3)
    return path


@pytest.fixture(scope="module")
def map_rows(force_map, gallery_cache, diagnosis_surfaces):
    return diagnose_many(force_map, radius_mm=R_MM, context=Context(cache_dir=gallery_cache, workers=2),
                         progress=False, command=["skin-indent", "diagnose", str(force_map)], **MAP_SETTINGS)


@MAP_GROUP
def test_force_map_rows_are_each_pixel_diagnosed_alone(force_map, map_rows, gallery_cache):
    assert [r.index for r in map_rows] == list(range(6))
    assert [(r.grid_x, r.grid_y) for r in map_rows] == [(0, 0), (1, 0), (2, 0), (0, 1), (1, 1), (2, 1)]
    assert [r.x_mm for r in map_rows[:3]] == pytest.approx([0.0, 0.5, 1.0])
    assert [r.verdict for r in map_rows] == ["none", "none", "offset", "offset", "stiffening", ""]
    assert "noise" in map_rows[5].error and map_rows[5].n_points == 100
    for row in map_rows[:5]:
        alone = diagnose(load_curve(force_map, radius_mm=R_MM, index=row.index),
                         context=Context(cache_dir=gallery_cache, workers=1), **MAP_SETTINGS)
        assert (row.verdict, row.model, row.E_kPa, row.misfit) == (alone.verdict, alone.current.model,
                                                                   alone.current.parameters["E_kPa"],
                                                                   alone.current.rms_mN / alone.noise_mN)
    assert map_rows[2].parameters["offset_mm"] == pytest.approx(0.02, abs=0.005)
    assert map_rows[0].E_kPa == pytest.approx(8.0, rel=0.05) and map_rows[1].E_kPa == pytest.approx(4.0, rel=0.05)


@MAP_GROUP
def test_force_map_figure_shows_the_verdict_of_each_pixel(map_rows, tmp_path):
    maps = force_maps(map_rows)
    assert list(maps) == [str(map_rows[0].file)] and len(maps[str(map_rows[0].file)]) == 6
    fig = map_figure(map_rows)
    verdict_ax, misfit_ax, modulus_ax = fig.axes[:3]
    codes = verdict_ax.collections[0].get_array().reshape(2, 3)  # rows of the map: y, then x
    colours = verdict_colours([r.outcome for r in map_rows])
    order = list(colours)
    for r in map_rows:
        assert order[int(codes[r.grid_y, r.grid_x])] == r.outcome
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[:4] == ["none (2)", "stiffening (1)", "offset (2)", f"{FAILED} (1)"]
    assert ("provisional (combinations untried)" in labels) == any(r.provisional for r in map_rows)
    misfit = misfit_ax.collections[0].get_array().reshape(2, 3)
    assert np.ma.is_masked(misfit[1, 2]) and misfit[0, 0] == pytest.approx(map_rows[0].misfit)
    modulus = modulus_ax.collections[0].get_array().reshape(2, 3)
    assert modulus[0, 1] == pytest.approx(map_rows[1].E_kPa)
    assert len(set(colours.values())) == len(colours)  # categorical: a colour per verdict
    paths = write_batch_figures(map_rows, tmp_path)
    assert [p.name for p in paths] == ["verdicts.png", "map.h5_map.png"]
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert read_provenance(p) == map_rows.provenance


@MAP_GROUP
def test_dask_cluster_gives_the_table_of_local_processes(force_map, map_rows, gallery_cache, tmp_path):
    distributed = pytest.importorskip("distributed", reason="Dask is not installed: pip install 'skin_indent[dask]'")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster, set_as_default=False) as client:
        on_dask = diagnose_many(force_map, radius_mm=R_MM, context=Context(cache_dir=gallery_cache, client=client),
                                progress=False, command=["skin-indent", "diagnose", str(force_map)], **MAP_SETTINGS)
    local, dask = (write_tsv(r, tmp_path / f"{name}.tsv") for r, name in ((map_rows, "local"), (on_dask, "dask")))

    def table(path):
        return [line for line in path.read_text().splitlines() if not line.startswith("#")]

    assert table(dask) == table(local) and len(table(local)) == 7


@MAP_GROUP
def test_a_diagnosis_in_a_worker_works_on_one_core_with_the_batch_cache(force_map, monkeypatch, tmp_path):
    """In a worker process the diagnosis gets one core (no process pool inside the batch's workers) and
    the batch's cache; a batch that runs here keeps the batch's context."""
    parent = os.getpid()

    def where(prepared, *, context, **settings):  # in the forked workers too
        raise ValueError(f"pid {'parent' if os.getpid() == parent else 'worker'}, workers {context.workers}, "
                         f"cache {context.cache_dir}, progress {context.progress}")

    monkeypatch.setattr("skin_indent.diagnosis.batch.diagnose", where)
    rows = diagnose_many(force_map, radius_mm=R_MM, context=Context(cache_dir=tmp_path, workers=2), progress=False)
    assert {r.error for r in rows} == {f"pid worker, workers 1, cache {tmp_path}, progress False"}
    rows = diagnose_many(force_map, radius_mm=R_MM, index=0, context=Context(cache_dir=tmp_path), progress=False)
    assert rows[0].error == f"pid parent, workers None, cache {tmp_path}, progress False"
    batch = Context(cache_dir=tmp_path, workers=3, progress=True)
    assert worker_context(batch, InProcess()) == Context(cache_dir=tmp_path, workers=3, progress=False)
    assert worker_context(batch, LocalProcesses(2)) == Context(cache_dir=tmp_path, workers=1, progress=False)


def test_settings_no_curve_could_take_are_refused_before_any_file_is_read(tmp_path):
    for kw, match in (({"candidates": ("gravity",)}, "gravity"), ({"add": ("friction",)}, "weighed"),
                      ({"max_rungs": -1}, "max_rungs")):
        with pytest.raises(ValueError, match=match):
            diagnose_many(tmp_path / "not-read.csv", **kw)


def _short(folder, name: str, rows: int):
    """The first ``rows`` rows of the bundled forearm curve, every 15th (row 0 at h = 0, the others in contact)."""
    m = load_csv(bundled_path("forearm_like.csv"))
    path = folder / f"{name}.csv"
    path.write_text("# radius_mm: 6.22\ndepth_mm,force_mN\n" + "".join(
        f"{d:.9g},{f:.9g}\n" for d, f in zip(m.depth_mm[::15][:rows], m.force_mN[::15][:rows])))
    return path


def test_a_curve_with_too_few_points_says_why_in_its_row(gallery_cache, tmp_path, capsys,
                                                          monkeypatch):
    """A 5-point curve (4 in contact) and a 4-point one (3 in contact): no row has a bare NaN. Without a noise
    level, each row's error says the points are too few to estimate it; with one, the 4-point curve is refused
    (fewer points in contact than the half-space's 2 parameters + 2) and the 5-point one is diagnosed with
    the candidates it cannot take not fitted (the verdict provisional, with why) and a flag naming the count."""
    five, four = _short(tmp_path, "five", 5), _short(tmp_path, "four", 4)
    context = Context(cache_dir=gallery_cache, workers=1)
    estimated = diagnose_many([five, four], context=context, progress=False, **CHEAP)
    assert [r.n_points for r in estimated] == [5, 4]
    assert all("too few to estimate the noise" in r.error and "--noise" in r.error for r in estimated)
    rows = diagnose_many([five, four], context=context, progress=False, noise_mN=0.05, **CHEAP)
    diagnosed, refused = rows
    assert refused.error == ("four.csv: 3 point(s) in contact for 2 fitted parameter(s) of neo-hooke, at least 4 "
                             "needed: a window that cuts the curve, a decimated export, or hold more parameters fixed "
                             "(--fix nu=0.5)")
    assert math.isnan(refused.misfit) and refused.outcome == FAILED
    assert not diagnosed.error and math.isfinite(diagnosed.misfit) and diagnosed.provisional
    assert diagnosed.flags == ("4 points in contact for 2 fitted parameters (fewer than 5 per parameter): too few to "
                               "judge the fit; a window that cuts the curve or a decimated export?",)
    assert not rows.trusted and set(diagnosed.untried) == {"offset", "layer", "stiffening"}
    alone = diagnose(load_csv(five), context=context, noise_mN=0.05, **CHEAP)
    assert alone.untried == dict.fromkeys(diagnosed.untried, "too few points: 4 in contact, fewer than each model's "
                                                             "fitted parameters + 2")
    assert alone.notes == list(diagnosed.flags) and "note: 4 points in contact" in alone.report()
    assert "+offset        not fitted: five.csv: 4 point(s) in contact for 3 fitted parameter(s) of neo-hooke+offset" \
        in alone.report()
    # the table: a NaN misfit only beside an error that says why
    with open(write_tsv(rows, tmp_path / "short.tsv")) as fh:
        table = list(csv.DictReader((line for line in fh if not line.startswith("#")), delimiter="\t"))
    for line in [*table, *(dict(zip(DIAGNOSIS_COLUMNS, (str(getattr(r, c)) for c in DIAGNOSIS_COLUMNS)))
                           for r in estimated)]:
        assert line["misfit"] != "nan" or line["error"], line
    assert table[0]["flags"].startswith("4 points in contact") and table[1]["error"].startswith("four.csv: 3 point(s)")
    # one curve on the command line: the refusal in one line, exit 2
    from skin_indent.cli import main

    monkeypatch.setenv("SKIN_INDENT_CACHE", str(gallery_cache))
    assert main(["diagnose", str(four), "--noise", "0.05", "--surfaces-only", "--max-rungs", "1", "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "3 point(s) in contact for 2 fitted parameter(s) of neo-hooke, at least 4" in err[0]


def test_a_model_too_large_for_the_curve_is_refused_before_its_surface_is_built(gallery_cache, tmp_path,
                                                                                 monkeypatch):
    """The 5-point curve's candidates with more parameters than its points can take (layer, stiffening)
    are refused from their parameter count: no response surface of theirs is built for nothing."""
    import skin_indent.fitting.multistart as multistart

    built = []
    real = multistart.elastic_core

    def watched(effects, **kw):
        built.append(tuple(effects))
        return real(effects, **kw)

    monkeypatch.setattr(multistart, "elastic_core", watched)
    d = diagnose(load_csv(_short(tmp_path, "five", 5)), context=Context(cache_dir=gallery_cache, workers=1),
                 noise_mN=0.05, **CHEAP)
    assert set(d.untried) == {"offset", "layer", "stiffening"}
    assert built and not any(e in key for key in built for e in ("layer", "stiffening")), built


def test_rows_in_text_and_json():
    row = DiagnosisRow(file="a/x.csv", index=0, radius_mm=R_MM, verdict="layer", provisional=True, model="neo-hooke+layer",
                       E_kPa=31.4, E_std_kPa=2.0, misfit=1.01, white=True, confounded_with=("layer", "offset"),
                       parameters={"E_kPa": 31.4, "thickness_mm": 0.93}, std={"E_kPa": 2.0, "thickness_mm": 0.2})
    assert verdict_line(row) == ("x.csv[0]: layer (provisional); final model neo-hooke+layer: E = 31.4 +- 2 kPa, "
                                 "misfit 1.01 x noise, white; nearly as good: offset")
    afm = DiagnosisRow(file="m.h5", index=3, radius_mm=0.02, verdict="none", model="neo-hooke", E_kPa=1.5,
                       E_std_kPa=0.01, misfit=1.0, white=True)
    assert "E = 1500 +- 10 Pa" in verdict_line(afm)
    assert verdict_line(DiagnosisRow(file="b.csv", error="bad")) == "b.csv: error: bad"
    d = DiagnosisRow(file="b.csv", error="bad").to_dict()
    assert d["E_kPa"] is None and d["flags"] == [] and "diagnosis" not in d
    json.dumps(d, allow_nan=False)


# ------------------------------------------------------------------ the command line
@MAP_GROUP
def test_cli_batch_of_a_force_map_and_a_bad_file(force_map, map_rows, gallery_cache, tmp_path, monkeypatch, capsys):
    from skin_indent.cli import main

    monkeypatch.setenv("SKIN_INDENT_CACHE", str(gallery_cache))
    bad = _bad_file(tmp_path)
    argv = ["diagnose", str(force_map), str(bad), "--radius", str(R_MM), "--surfaces-only", "--max-rungs", "1",
            "--candidates", "offset,stiffening", "--out", str(tmp_path / "v.tsv"), "-q"]
    assert main(argv) == 3  # a curve failed: --strict is the default of a batch
    out, err = capsys.readouterr()
    assert out.strip().splitlines() == [*(verdict_line(r) for r in map_rows), f"broken.csv: error: {_error_of(bad)}",
                                        (f"7 curves: 2 failed; verdicts: failed 2, none 2, offset 2, stiffening 1; "
                                         f"wrote {tmp_path / 'v.tsv'}")]
    # the only warnings: how a curve's final fit ended where its values are not a result (fitting.ended)
    assert all(line.startswith("skin-indent diagnose: warning: ") and "not a result" in line
               for line in err.splitlines()), err
    prov = read_provenance(tmp_path / "v.tsv")
    assert prov["command"] == ["skin-indent", *argv] and "api" not in prov
    table = [line.split("\t") for line in (tmp_path / "v.tsv").read_text().splitlines() if not line.startswith("#")]
    assert [line[DIAGNOSIS_COLUMNS.index("verdict")] for line in table[1:]] == [r.verdict for r in map_rows] + [""]
    # one curve of the map with --out and --plot: a batch of one, its report, the verdicts and the map of that pixel
    other = tmp_path / "empty.csv"
    other.write_text("depth_mm,force_mN\n")
    plots = tmp_path / "plots"
    assert main(["diagnose", str(force_map), str(other), "--index", "2", "--radius", str(R_MM), "--surfaces-only",
                 "--max-rungs", "1", "--candidates", "offset,stiffening", "--plot", str(plots), "--no-strict",
                 "-q"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0] == verdict_line(map_rows[2]) and lines[1] == "empty.csv[2]: error: empty.csv: header only, no data rows"
    assert {p.name for p in plots.iterdir()} == {"verdicts.png", "map.h5_map.png", "map.h5_2"}
    page = plots / "map.h5_2" / "index.html"
    assert "offset" in page.read_text()
    assert read_provenance(plots / "map.h5_2" / "fit.png")["curve"] == {"file": str(force_map), "index": 2}
    assert read_provenance(plots / "verdicts.png")["command"][:2] == ["skin-indent", "diagnose"]
    assert main(["diagnose", str(bad), str(other), "-q"]) == 3
    capsys.readouterr()
    # --index alone: one curve of the map is the single diagnosis, its report as before
    assert main(["diagnose", str(force_map), "--index", "2", "--radius", str(R_MM), "--surfaces-only",
                 "--max-rungs", "1", "--candidates", "offset,stiffening", "-q"]) == 0
    assert capsys.readouterr().out.startswith("data: map.h5[2] (100 points")


def _error_of(path) -> str:
    """The one-line error of the row of a file that cannot be read."""
    return diagnose_many(path).pop().error


@pytest.mark.parametrize("extra, message", [
    (["{curve}", "{missing}"], "no such file or folder"),
    (["{curve}", "{curve2}", "--report", "{tmp}"], "--report DIR is for one curve"),
    (["{curve}", "--plot", "{tmp}"], "--plot: for a batch"),
    (["{curve}", "{curve2}", "--recursive"], "--recursive searches folders"),
    (["{curve}", "--segments", "approach,unload"], "--segments must be some of"),
    (["{curve}", "{curve2}", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "--workers sets local"),
    (["{curve}", "{curve2}", "--candidates", "gravity"], "gravity"),
])
def test_cli_user_errors_exit_2_with_one_line(extra, message, tmp_path, capsys):
    from skin_indent.cli import main

    paths = {"curve": HIDDEN / "v05_offset.csv", "curve2": HIDDEN / "v01_clean.csv", "missing": tmp_path / "no.csv",
             "tmp": tmp_path / "out"}
    assert main(["diagnose", *(a.format(**paths) for a in extra)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("skin-indent diagnose: error: ") and message in err[0], err


def test_cli_batch_interrupted_exits_130(monkeypatch, capsys):
    from skin_indent.cli import main

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("skin_indent.diagnosis.diagnose_many", interrupted)
    assert main(["diagnose", str(HIDDEN / "v05_offset.csv"), str(HIDDEN / "v01_clean.csv")]) == 130
    assert capsys.readouterr().err.strip() == "skin-indent diagnose: interrupted"
