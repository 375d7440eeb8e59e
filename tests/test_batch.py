"""Many curves at a time (skin_indent.batch), plots of a fit (skin_indent.report.fit_figure), provenance.

A folder of small synthetic AFM-like curves (finite-element curves of the coarse mesh,
R = 20 um, contact past the first samples, a force baseline and noise) plus two bad files
is fitted in one batch on 2 worker processes: one row per curve with the right E, one row
with a one-line error per bad file, a TSV with a provenance header, plots and fit CSVs.
The force map of tests/data/instrument-files gives one row per curve with its map position.
The surfaces come from the gallery cache, where the coarse unit-radius ones are built once per
run (conftest.py ``coarse_unit_surfaces``, shared with test_api.py and test_real_data.py).
"""

import hashlib
import os

import numpy as np
import pytest
from _data import DATA

from skin_indent import NeoHooke, SphericalIndenter, simulate
from skin_indent.batch import TSV_COLUMNS, BatchRow, expand_paths, fit_many
from skin_indent.report.batch_table import summary_figure, write_tsv
from skin_indent.runtime.context import Context
from skin_indent.report.fit_figure import fit_arrays, plot_fit, write_fit_csv
from skin_indent.measurement import load_csv
from skin_indent.runtime.provenance import (file_identity, provenance, provenance_comment_lines, read_provenance,
                                    with_provenance)

MAP = DATA / "instrument-files" / "fmt-jpk-fd_map-data-reference-points.jpk-force-map"
R_MM = 0.02
NU = 0.45
E_KPA = {"cell_a.csv": 1.0, "cell_b.csv": 3.0, "cell_c.csv": 0.5}  # AFM-like: 0.5-3 kPa, forces of nN


def _mode(path) -> int:
    return os.stat(path).st_mode & 0o777


def _expected_mode() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def _write_curve(path, E_kPa, seed, radius_comment=True):
    """A recorded-like curve: 2 um of approach before contact, 6 um of indentation, baseline and noise."""
    rng = np.random.default_rng(seed)
    contact_mm = 0.002
    curve = simulate(NeoHooke(E_kPa=E_kPa, nu=NU), SphericalIndenter(radius_mm=R_MM), depth_mm=0.006, points=60,
                     mesh="coarse")
    before = np.linspace(0.0, contact_mm, 21)  # 20 samples before contact, the 21st at contact
    depth = np.r_[before, contact_mm + curve.depth_mm]
    force = np.r_[np.zeros(before.size), curve.force_mN]
    peak = force.max()
    force = force + 0.02 * peak + 1e-3 * peak * rng.standard_normal(depth.size)  # baseline, noise
    time = np.arange(depth.size) * 0.01
    lines = ["# synthetic AFM-like curve (skin_indent.simulate, coarse mesh)"]
    if radius_comment:
        lines.append(f"# radius_um: {R_MM * 1e3:g}")
    lines.append("time_s,depth_um,force_N")
    lines += [f"{t:.4f},{d * 1e3:.6f},{f * 1e-3:.6e}" for t, d, f in zip(time, depth, force)]
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    d = tmp_path_factory.mktemp("curves")
    for seed, (name, E) in enumerate(E_KPA.items()):
        _write_curve(d / name, E, seed)
    (d / "broken.csv").write_text("time_s,depth_um,force_N\n0,0,0\n1,oops,1\n")  # not a number
    (d / "notes.md").write_text("not a curve")  # not searched: no readable suffix
    (d / ".hidden.csv").write_text("hidden")  # not searched: hidden
    return d


@pytest.fixture(scope="module")
def batch(folder, context, tmp_path_factory):
    plots = tmp_path_factory.mktemp("plots")
    rows = fit_many([folder], fixed={"nu": NU}, mesh="coarse", context=context, progress=False, keep_fits=True,
                    plot_dir=plots, command=["skin-indent", "fit", str(folder)])
    return rows, plots


# ------------------------------------------------------------------ the batch
def test_folder_is_expanded_to_its_readable_files(folder, tmp_path):
    out = tmp_path / "with_outputs"
    out.mkdir()
    (out / "a.csv").write_text("depth_mm,force_mN\n0,0\n")
    write_tsv([BatchRow(file="a.csv", error="x")], out / "results.tsv", provenance(["skin-indent"]))
    assert [p.name for p in expand_paths(out)] == ["a.csv"]  # the package's own outputs are left out
    assert [p.name for p in expand_paths(folder)] == ["broken.csv", "cell_a.csv", "cell_b.csv", "cell_c.csv"]
    assert expand_paths([folder / "cell_a.csv", folder, folder / "cell_a.csv"])[0].name == "cell_a.csv"
    assert len(expand_paths([folder / "cell_a.csv", folder])) == 4  # each file once


def test_one_row_per_curve_with_the_right_modulus(batch):
    rows, _ = batch
    assert [r.label for r in rows] == ["broken.csv", "cell_a.csv[0]", "cell_b.csv[0]", "cell_c.csv[0]"]
    for row in rows[1:]:
        E = E_KPA[row.label[:-3]]
        assert not row.error, row.error
        assert row.E_kPa == pytest.approx(E, rel=0.03), row
        assert row.nu == NU and row.radius_mm == R_MM
        assert row.contact_point_mm == pytest.approx(0.002, abs=2e-4)
        assert row.E_star_kPa == pytest.approx(row.E_kPa / (1 - NU**2))
        assert row.baseline_mN > 0 and row.noise_mN > 0 and row.misfit > 0 and row.verdict
        assert row.fit_from_mm < row.contact_point_mm < row.fit_to_mm and row.n_points > 10
        assert row.surface and row.fit is not None
    assert rows.n_failed == 1 and len(rows.surfaces) == 1  # one surface for the three curves


def test_a_bad_file_is_one_row_with_a_one_line_error(batch):
    bad = batch[0][0]
    assert bad.index is None and bad.error.startswith("broken.csv")
    assert "\n" not in bad.error and np.isnan(bad.E_kPa) and not bad.trusted


def test_tsv_has_provenance_and_one_row_per_curve(batch, folder, tmp_path):
    rows, _ = batch
    path = write_tsv(rows, tmp_path / "results.tsv")
    assert _mode(path) == _expected_mode()  # 0644 under the usual umask 022, not a temporary file's 0600
    text = path.read_text().splitlines()
    header = [line for line in text if line.startswith("#")]
    table = [line for line in text if not line.startswith("#")]
    assert table[0].split("\t") == list(TSV_COLUMNS) and len(table) == 1 + len(rows)
    assert all(len(line.split("\t")) == len(TSV_COLUMNS) for line in table)
    prov = read_provenance(path)
    assert prov["command"] == ["skin-indent", "fit", str(folder)] and prov["settings"]["mesh"] == "coarse"
    assert prov["settings"]["fixed"] == {"nu": NU} and prov["surface"][0]["hash"]
    digests = {os.path.basename(i["path"]): i["sha256"] for i in prov["inputs"]}
    for name in ("broken.csv", *E_KPA):
        assert digests[name] == hashlib.sha256((folder / name).read_bytes()).hexdigest()
    assert header[0].startswith("# written by skin_indent")
    E = dict(zip(TSV_COLUMNS, table[2].split("\t")))["E_kPa"]
    assert float(E) == pytest.approx(rows[1].E_kPa, rel=1e-9)


def test_plot_and_fit_csv_per_curve(batch):
    rows, plots = batch
    for row in rows[1:]:
        png, csv = plots / f"{row.label[:-3]}_0.png", plots / f"{row.label[:-3]}_0.csv"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and _mode(png) == _expected_mode()
        assert _mode(csv) == _expected_mode()
        lines = [line for line in csv.read_text().splitlines() if not line.startswith("#")]
        names = lines[0].split(",")
        assert names == ["depth_mm", "force_mN", "model_mN", "residual_mN", "indentation_mm"]
        data = dict(zip(names, np.loadtxt(lines[1:], delimiter=",", ndmin=2).T))
        scale = np.abs(data["force_mN"]).max()
        np.testing.assert_allclose(data["residual_mN"], data["force_mN"] - data["model_mN"], atol=1e-9 * scale)
        np.testing.assert_allclose(data["residual_mN"], row.fit.residuals_mN, atol=1e-9 * scale)
        assert np.sqrt(np.mean(data["residual_mN"] ** 2)) == pytest.approx(row.rms_mN, rel=1e-6)
        prov = read_provenance(csv)
        assert [os.path.basename(i["path"]) for i in prov["inputs"]] == [row.label[:-3]]
        again = load_csv(csv)  # the fit CSV reads back as a curve with its radius
        assert again.radius_mm == R_MM and again.n_points == data["depth_mm"].size


def test_plot_fit_and_write_fit_csv_directly(batch, tmp_path):
    fit = batch[0][1].fit
    a = fit_arrays(fit)
    np.testing.assert_array_equal(a["residual_mN"], fit.residuals_mN)
    np.testing.assert_allclose(a["model_mN"] + a["residual_mN"], a["force_mN"])
    assert plot_fit(fit, tmp_path / "sub" / "fit.png").stat().st_size > 1000
    out = write_fit_csv(fit, tmp_path / "fit.csv")  # no provenance given: the fit's own, its API call
    assert read_provenance(out)["api"] == "skin_indent.fit" and read_provenance(out) == fit.provenance


def test_summary_figure(batch, tmp_path):
    path = summary_figure(batch[0], tmp_path / "summary.png")
    assert path.read_bytes()[:4] == b"\x89PNG" and _mode(path) == _expected_mode()
    assert summary_figure([], tmp_path / "empty.png").exists()


def test_radius_given_and_index(folder, context, tmp_path):
    """The radius argument replaces a missing radius comment; index=1 of a CSV is a one-line error row."""
    _write_curve(tmp_path / "plain.csv", 1.0, 7, radius_comment=False)
    rows = fit_many(tmp_path / "plain.csv", radius_mm=R_MM, fixed={"nu": NU}, mesh="coarse",
                    context=Context(cache_dir=context.cache_dir, workers=1), progress=False)
    assert len(rows) == 1 and rows[0].E_kPa == pytest.approx(1.0, rel=0.03)
    rows = fit_many(folder / "cell_a.csv", index=1, mesh="coarse", context=context, progress=False)
    assert len(rows) == 1 and "curve 1 requested" in rows[0].error and "\n" not in rows[0].error


# ------------------------------------------------------------------ a force map
def test_force_map_gives_one_row_per_curve(context):
    pytest.importorskip("afmformats")
    rows = fit_many(MAP, radius_mm=0.01864, mesh="coarse", context=context, progress=False)
    assert [r.index for r in rows] == [0, 1, 2]
    assert [(r.grid_x, r.grid_y) for r in rows] == [(9, 4), (20, 5), (16, 16)]
    assert all(not r.error and np.isfinite(r.E_kPa) and r.x_mm is not None for r in rows)
    assert all(r.radius_mm == 0.01864 for r in rows)
    assert rows[1].E_kPa > 10 * max(rows[0].E_kPa, rows[2].E_kPa)  # the substrate is much stiffer


# ------------------------------------------------------------------ provenance
def test_provenance_record_and_comment_lines(tmp_path):
    f = tmp_path / "a.csv"
    f.write_bytes(b"depth_mm,force_mN\n0,0\n")
    prov = provenance(["skin-indent", "fit"], inputs=[f, f, tmp_path / "missing.csv"],
                      settings={"window": (0.0, 0.1), "nu": np.float64(0.45)})
    assert prov["inputs"][0] == {"path": str(f.resolve()), "sha256": hashlib.sha256(f.read_bytes()).hexdigest(),
                                 "bytes": f.stat().st_size}
    assert len(prov["inputs"]) == 2 and "error" in prov["inputs"][1]
    assert prov["settings"] == {"window": [0.0, 0.1], "nu": 0.45}
    assert prov["libraries"]["numpy"] == np.__version__ and prov["skin_indent"]
    lines = provenance_comment_lines(prov)
    assert all(line.startswith("# ") and "\n" not in line for line in lines)
    assert read_provenance(lines) == prov
    assert with_provenance({"E_kPa": 1.0}, prov)["provenance"] == prov
    assert file_identity(tmp_path)["error"]  # a folder is not an input file


def test_batch_row_to_dict_is_json_safe():
    import json

    d = BatchRow(file="x.csv", error="bad").to_dict()
    assert d["E_kPa"] is None and d["flags"] == [] and "fit" not in d
    json.dumps(d, allow_nan=False)
