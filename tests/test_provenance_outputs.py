"""Every file the package writes says how it was made, and a fit's settings can be replayed.

Each output of ``fit`` (JSON, CSV, PNG with ``--plot``), ``diagnose`` (``--json``, the HTML
report and its figures), ``simulate`` (CSV), a batch (TSV) and the demo's summary names the
package version and the sha256 of its inputs; the API's results (``si.fit``, ``si.diagnose``)
name their call. A profile saved with ``--save-profile``, or the provenance of any fit output
given as ``--profile``, reproduces the fit's numbers exactly; a malformed profile is one line
on stderr and exit status 2.

Cheap: the bundled Chiaro AFM curve on the coarse unit-radius surfaces of the gallery cache
(conftest.py ``coarse_unit_surfaces``), a 5-point coarse simulation, and a diagnosis that
examines the half-space with one candidate (no climb, no finite elements in the loop).
"""

import hashlib
import json
import re
import shutil
import sys
import types

import numpy as np
import pytest
from _data import DATA

import skin_indent as si
from skin_indent.cli import main
from skin_indent.data import bundled_path
from skin_indent.demo import write_summary
from skin_indent.fitting import profile as profile_module
from skin_indent.fitting.profile import profile_from_settings, read_profile, write_profile
from skin_indent.measurement import load_csv, measurement_from_arrays
from skin_indent.report import plot_fit, save_figure
from skin_indent.runtime.context import Context
from skin_indent.runtime.provenance import data_identity, png_metadata, provenance, read_provenance

CURVE = bundled_path("afm_chiaro_AEBP1_R27.5um.csv")  # R = 27.5 um in its header
CLEAN = DATA / "hidden-effects" / "v01_clean.csv"
FIT = ["--mesh", "coarse", "--fix", "nu=0.45", "--contact", "fit", "--window", "0:0.01"]


def sha256(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def assert_names_version_and_inputs(prov, *inputs, command=None):
    """``prov`` names this version of the package and each input file with its sha256."""
    assert prov["skin_indent"] == si.__version__
    assert set(prov["libraries"]) == {"numpy", "scipy", "scikit-fem"}
    recorded = {i["path"]: i["sha256"] for i in prov["inputs"] if "path" in i}
    for path in inputs:
        assert recorded[str(path.resolve())] == sha256(path)
    if command is not None:
        assert prov["command"] == ["skin-indent", *command]


@pytest.fixture()
def cache(coarse_unit_surfaces, monkeypatch):
    """The CLI finds the coarse unit surfaces in the gallery cache."""
    monkeypatch.setenv("SKIN_INDENT_CACHE", str(coarse_unit_surfaces))
    return coarse_unit_surfaces


def fit_json(capsys, *argv):
    """``skin-indent fit ... --json``: (exit status, the JSON object)."""
    code = main(["fit", *map(str, argv), "--json"])
    return code, json.loads(capsys.readouterr().out)


# ------------------------------------------------------------------ fit: JSON, CSV, PNG and profiles
@pytest.fixture()
def fitted(cache, tmp_path, capsys):
    """One fit with every output: JSON (saved), CSV and PNG (``--plot``), a saved profile."""
    argv = [str(CURVE), *FIT, "--plot", str(tmp_path / "plot"), "--save-profile", str(tmp_path / "profile.json")]
    code, out = fit_json(capsys, *argv)
    assert code == 0
    (tmp_path / "fit.json").write_text(json.dumps(out))
    return argv, out, tmp_path


def test_fit_outputs_name_the_version_command_and_input_sha256(fitted):
    argv, out, tmp = fitted
    assert_names_version_and_inputs(out["provenance"], CURVE, command=["fit", *argv, "--json"])
    assert out["provenance"]["settings"]["fixed"] == {"nu": 0.45}
    csv, png = tmp / "plot" / f"{CURVE.stem}.csv", tmp / "plot" / f"{CURVE.stem}.png"
    for path in (csv, png, tmp / "fit.json"):
        assert read_provenance(path) == out["provenance"], path
    measurement = load_csv(csv)  # the fit CSV reads back as a curve, radius included
    assert measurement.radius_mm == pytest.approx(0.0275)


def test_a_saved_profile_reproduces_the_fit_exactly(fitted, capsys):
    _, out, tmp = fitted
    assert read_profile(tmp / "profile.json") == {"method": "lsq", "mesh": "coarse", "fix": {"nu": 0.45},
                                                  "contact": "fit", "window": [0.0, 0.01]}
    code, again = fit_json(capsys, CURVE, "--profile", tmp / "profile.json")
    assert code == 0
    assert again["parameters"] == out["parameters"] and again["std"] == out["std"]
    assert again["provenance"]["settings"] == out["provenance"]["settings"]
    recorded = {i["path"] for i in again["provenance"]["inputs"]}
    assert str((tmp / "profile.json").resolve()) in recorded  # the profile is an input of the run


@pytest.mark.parametrize("output", ["fit.json", "plot/{stem}.csv", "plot/{stem}.png"])
def test_the_provenance_of_a_fit_output_replays_as_a_profile(fitted, capsys, output):
    _, out, tmp = fitted
    code, again = fit_json(capsys, CURVE, "--profile", tmp / output.format(stem=CURVE.stem))
    assert code == 0
    assert again["parameters"] == out["parameters"]


@pytest.mark.skipif(sys.version_info < (3, 11), reason="tomllib is Python >= 3.11")
def test_a_toml_profile_and_the_command_line_over_it(fitted, capsys):
    _, out, tmp = fitted
    toml = write_profile(read_profile(tmp / "profile.json"), tmp / "profile.toml")
    assert "[fix]" in toml.read_text()
    code, again = fit_json(capsys, CURVE, "--profile", toml)
    assert code == 0 and again["parameters"] == out["parameters"]
    code, other = fit_json(capsys, CURVE, "--profile", toml, "--fix", "nu=0.4", "--method", "lsq")
    assert code == 0
    assert other["parameters"]["nu"] == 0.4 and other["provenance"]["settings"]["fixed"] == {"nu": 0.4}
    assert other["provenance"]["settings"]["window_mm"] == [0.0, 0.01]  # the rest from the profile


def test_a_model_fit_with_a_prior_replays_from_its_json(cache, tmp_path, capsys):
    """The model path (``--prior`` implies it): its JSON output, given as a profile, gives the same numbers."""
    code, out = fit_json(capsys, CLEAN, "--prior", "nu=0.45:0.02")
    assert code == 0 and out["provenance"]["settings"]["priors"] == {"nu": [0.45, 0.02]}
    # the surface the fit used, in the result and in its provenance (was {} and null)
    (surface,) = out["surface"]
    assert out["provenance"]["surface"] == out["surface"] and surface["type"] == "ResponseSurface"
    assert re.fullmatch(r"[0-9a-f]{64}", surface["hash"]) and surface["settings"]["mesh"] == "coarse"
    (tmp_path / "fit.json").write_text(json.dumps(out))
    code, again = fit_json(capsys, CLEAN, "--profile", tmp_path / "fit.json")
    assert code == 0
    assert again["model"] == "neo-hooke" and again["parameters"] == out["parameters"]


def test_a_profile_is_saved_only_after_the_fit_succeeded(cache, tmp_path, capsys):
    """A fit refused (h/R > 0.5: the radius in mm given as um), or a batch where no curve could be
    fitted, leaves no profile; a successful one writes it after its report."""
    saved = tmp_path / "profile.json"
    assert main(["fit", str(CURVE), "--radius", "0.0000275", "--save-profile", str(saved), *FIT]) == 2
    assert "deeper than the sphere's radius" in capsys.readouterr().err and not saved.exists()
    folder = tmp_path / "bad"
    folder.mkdir()
    (folder / "empty.csv").write_text("depth_mm,force_mN\n")
    assert main(["fit", str(folder), "--save-profile", str(saved), "--workers", "1", *FIT]) == 3
    assert "1 failed" in capsys.readouterr().out and not saved.exists()
    assert main(["fit", str(CURVE), "--save-profile", str(tmp_path / "nowhere" / "p.json"), *FIT]) == 2
    assert "no such folder" in capsys.readouterr().err
    assert main(["fit", str(CURVE), "--save-profile", str(saved), *FIT]) == 0
    out = capsys.readouterr().out
    assert out.rstrip().endswith(f"wrote the profile of this fit to {saved}") and "E_Pa" in out
    assert read_profile(saved)["window"] == [0.0, 0.01]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith("profile")] == ["profile.json"]  # no temp file


@pytest.mark.parametrize("content, message", [
    ("{not json", "not JSON (line 1"),
    ('{"method": "newton"}', "method must be one of"),
    ('{"windw": [0, 1]}', "unknown setting 'windw'"),
    ('{"window": [0.5, 0.1]}', "window must satisfy"),
    ('{"fix": {"nu": "soft"}}', "fix nu must be a number"),
    ('["lsq"]', "a profile is a table of settings"),
    ("# a comment\ndepth_mm,force_mN\n1,2\n", "no provenance header"),
])
def test_a_malformed_profile_is_a_one_line_error(tmp_path, capsys, content, message):
    bad = tmp_path / "bad.json"
    bad.write_text(content)
    assert main(["fit", str(CURVE), "--profile", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"skin-indent fit: error: profile {bad}: ") and message in err


def test_a_missing_or_toml_profile_without_tomllib_is_a_one_line_error(tmp_path, capsys, monkeypatch):
    assert main(["fit", str(CURVE), "--profile", str(tmp_path / "nope.json")]) == 2
    assert "No such file" in capsys.readouterr().err
    toml = tmp_path / "p.toml"
    toml.write_text('method = "lsq"\n')
    monkeypatch.setattr(profile_module, "sys", types.SimpleNamespace(version_info=(3, 10, 12)))
    assert main(["fit", str(CURVE), "--profile", str(toml)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "needs Python >= 3.11" in err


# ------------------------------------------------------------------ the API
def test_api_results_record_their_call(coarse_unit_surfaces, tmp_path):
    m = load_csv(CURVE)
    result = si.fit(m, mesh="coarse", fixed={"nu": 0.45}, context=Context(cache_dir=coarse_unit_surfaces))
    prov = result.to_dict()["provenance"]
    assert prov["api"] == "skin_indent.fit" and prov["skin_indent"] == si.__version__
    assert prov["inputs"] == [data_identity(m)] and prov["surface"] == result.to_dict()["surface"]
    assert profile_from_settings(prov["settings"]) == {"mesh": "coarse", "fix": {"nu": 0.45}}  # replayable
    changed = measurement_from_arrays(m.depth_mm * 1.001, m.force_mN, m.time_s, m.source)
    assert data_identity(changed)["data_sha256"] != prov["inputs"][0]["data_sha256"]
    figure = plot_fit(result, tmp_path / "api.png")  # a figure of the API's fit: its call
    assert read_provenance(figure)["api"] == "skin_indent.fit"


# ------------------------------------------------------------------ diagnose
def test_diagnose_json_and_report_carry_provenance(cache, tmp_path, capsys):
    argv = ["diagnose", str(CLEAN), "--candidates", "offset", "--max-rungs", "0", "--surfaces-only", "--mesh",
            "coarse", "--json", "--report", str(tmp_path / "report")]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    prov = out["provenance"]
    assert_names_version_and_inputs(prov, CLEAN, command=argv)
    assert prov["settings"]["max_rungs"] == 0 and prov["settings"]["mesh"] == "coarse"
    page = (tmp_path / "report" / "index.html").read_text()
    assert 'id="provenance-table"' in page and sha256(CLEAN) in page and si.__version__ in page
    embedded = re.search(r'<script type="application/json" id="provenance">(.*?)</script>', page, re.S).group(1)
    assert json.loads(embedded) == prov
    for png in ("fit.png", "residuals.png", "ladder.png"):
        assert read_provenance(tmp_path / "report" / png) == prov


def test_the_api_diagnosis_records_its_call(cache):
    diag = si.diagnose(load_csv(CLEAN), candidates=["offset"], max_rungs=0, in_loop=False, mesh="coarse",
                       progress=False)
    prov = diag.to_dict()["provenance"]
    assert prov["api"] == "skin_indent.diagnose"
    assert prov["settings"] == {"candidates": ["offset"], "max_rungs": 0, "in_loop": False, "mesh": "coarse"}


# ------------------------------------------------------------------ simulate
def test_simulate_csv_has_provenance_and_model_and_loads_back(tmp_path):
    out = tmp_path / "curve.csv"
    argv = ["simulate", "--E", "8", "--nu", "0.45", "--radius", "2", "--depth", "0.1", "--points", "5", "--mesh",
            "coarse", "--out", str(out)]
    assert main(argv) == 0
    prov = read_provenance(out)
    assert_names_version_and_inputs(prov, command=argv)
    assert prov["settings"]["E"] == 8.0 and prov["settings"]["material"] == "neo-hooke"
    model = next(json.loads(line.split(": ", 1)[1]) for line in out.read_text().splitlines()
                 if line.startswith("# model: "))
    assert model["parameters"] == {"E_kPa": 8.0, "nu": 0.45} and model["radius_mm"] == 2.0
    assert model["law"] == "NeoHooke" and model["mesh"].startswith("coarse")
    measurement = load_csv(out)
    assert measurement.radius_mm == 2.0  # from the radius comment
    assert np.allclose(measurement.depth_mm, 0.02 * np.arange(1, 6)) and np.all(measurement.force_mN > 0)


# ------------------------------------------------------------------ batch
def test_batch_tsv_names_version_and_input_sha256_and_replays(cache, tmp_path, capsys):
    folder = tmp_path / "curves"
    folder.mkdir()
    shutil.copy(CURVE, folder / CURVE.name)
    table = tmp_path / "results.tsv"
    argv = ["fit", str(folder), "--out", str(table), "--workers", "1", *FIT, "--no-strict"]
    assert main(argv) == 0
    capsys.readouterr()
    prov = read_provenance(table)
    assert_names_version_and_inputs(prov, folder / CURVE.name, command=argv)
    lines = [line for line in table.read_text().splitlines() if not line.startswith("#")]
    row = dict(zip(lines[0].split("\t"), lines[1].split("\t")))
    code, again = fit_json(capsys, folder / CURVE.name, "--profile", table)  # the TSV header as a profile
    assert code == 0
    assert f"{again['parameters']['E_kPa']:.10g}" == row["E_kPa"]


# ------------------------------------------------------------------ demo and figures
def test_demo_summary_is_written_with_its_provenance(tmp_path):
    prov = provenance(["skin-indent", "demo"], inputs=[bundled_path("forearm_like.csv")],
                      settings={"window_mm": [0.05, 0.6]})
    path = write_summary(tmp_path / "demo.json", {"data": "forearm_like.csv", "noise_mN": float("nan")}, prov)
    summary = json.loads(path.read_text())
    assert summary["noise_mN"] is None  # valid JSON: NaN is null
    assert read_provenance(path) == prov
    assert_names_version_and_inputs(summary["provenance"], bundled_path("forearm_like.csv"), command=["demo"])


def test_save_figure_puts_the_record_in_the_png(tmp_path):
    from matplotlib.figure import Figure

    prov = provenance(["skin-indent", "fit", "a.csv"], settings={"mesh": "coarse"})
    fig = Figure()
    fig.add_subplot().plot([0, 1], [0, 1])
    path = save_figure(fig, tmp_path / "f.png", prov)
    assert read_provenance(path) == prov
    from PIL import Image

    with Image.open(path) as image:
        assert image.text["Software"] == f"skin_indent {si.__version__}"
        assert image.text["Source"] == "skin-indent fit a.csv"
    assert png_metadata(None) == {"Software": f"skin_indent {si.__version__}"}
