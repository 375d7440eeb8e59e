"""The HTML page of a diagnosis (skin_indent.report.diagnosis_page) and the surfaces in its provenance.

- the page is rendered by jinja2 from a template shipped as package data, autoescaped, and
  shows the Diagnosis's numbers (the same as its JSON); the template loops over curves;
- the provenance of a diagnosis (API, ``diagnose --json``, the page) names every surface its
  fits used: the half-space's response surface and each effect surface by hash, the
  finite-element model in the loop by what its runs solve.

A diagnosis of the clean hidden-effect curve with two candidates, no climb, on the coarse
surfaces the suite builds once (conftest.py ``diagnosis_surfaces``).
"""

import fnmatch
import hashlib
import importlib.resources
import json
import re
from pathlib import Path

import pytest
from _data import DATA

from skin_indent.cli import main
from skin_indent.diagnosis import diagnose
from skin_indent.measurement import load_csv, measurement_from_arrays
from skin_indent.models.fe_core import FECore
from skin_indent.report import diagnosis_page
from skin_indent.report.diagnosis_page import page_context, provenance_rows, render_page, write_report
from skin_indent.runtime.provenance import provenance, read_provenance, surface_identity

CLEAN = DATA / "hidden-effects" / "v01_clean.csv"
ROOT = Path(__file__).resolve().parents[1]
#: markup a file name or a setting could carry
MARKUP = '<img src=x onerror="alert(1)">'
SCRIPT = "</script><script>alert(1)</script>"


@pytest.fixture(scope="module")
def diag(gallery_cache, hidden, diagnosis_surfaces):
    """The clean curve against offset and stiffening (an effect surface), no climb."""
    return diagnose(hidden["v01_clean"], candidates=("offset", "stiffening"), max_rungs=0, in_loop=False,
                    cache_dir=gallery_cache, mesh="coarse", workers=1, progress=False)


def _rows(page: str) -> list[tuple]:
    return re.findall(r"<tr><td>([^<]*)</td><td>([^<]*)</td><td>([^<]*)</td><td>(yes|no)</td><td>(.*?)</td>", page)


def _embedded(page: str) -> dict:
    return json.loads(re.search(r'<script type="application/json" id="provenance">(.*?)</script>', page,
                                re.S).group(1))


# ------------------------------------------------------------------ the template
def test_the_page_template_is_package_data_and_jinja2_a_dependency():
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    template = importlib.resources.files("skin_indent.report") / "templates" / diagnosis_page.TEMPLATE
    assert template.is_file() and "{%- for curve in curves %}" in template.read_text()
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    globs = project["tool"]["setuptools"]["package-data"]["skin_indent.report"]
    assert any(fnmatch.fnmatch(f"templates/{diagnosis_page.TEMPLATE}", g) for g in globs)
    assert any(re.match(r"jinja2\b", d) for d in project["project"]["dependencies"])


def test_the_page_shows_the_numbers_of_the_diagnosis(diag, tmp_path):
    page = write_report(diag, tmp_path).read_text()
    out = diag.to_dict()
    assert page.count("<section") == 1 and page.count("data:image/png;base64,") == 3
    assert f"Verdict: {diag.verdict}" in page and f"effective sample size {diag.n_effective:.1f}" in page
    models = {r["model"]: r for r in (*out["ladder"], *out["ranking"])}
    rows = _rows(page)
    assert [r[0] for r in rows] == [f.model for f in diagnosis_page._models(diag)]
    for model, rms, bic, white, params in rows:
        row = models[model]
        assert (rms, bic, white) == (format(row["rms_mN"], ".4g"), format(row["bic"], ".1f"),
                                     "yes" if row["white"] else "no")
        shown = dict(re.findall(r"(\w+) = (\S+) &plusmn;", params))
        assert shown == {k: format(v, ".4g") for k, v in row["parameters"].items()}, (model, params)
    assert 'name="generator" content="skin_indent ' in page  # the template's, not a hand-written page


def test_the_page_shows_the_notes_of_the_diagnosis(diag, tmp_path):
    """The notes the terminal report prints (``note: ...``) are on the page too, escaped."""
    import dataclasses

    noted = dataclasses.replace(diag, notes=["the surface interpolates the fitted parameters to about 2.6% <here>"])
    page = write_report(noted, tmp_path).read_text()
    assert "<h2>Notes</h2>" in page and "to about 2.6% &lt;here&gt;</li>" in page
    assert "note: the surface interpolates the fitted parameters to about 2.6% <here>" in noted.report()
    assert "<h2>Notes</h2>" not in write_report(dataclasses.replace(diag, notes=[]), tmp_path / "none").read_text()


def test_the_template_loops_over_curves_with_one_provenance(diag, tmp_path):
    paths = diagnosis_page.figures(diag, tmp_path)
    prov = provenance(["skin-indent", "diagnose"], settings={"mesh": "coarse"}, surface=diag.surfaces)
    page = render_page([page_context(diag, paths), page_context(diag)], prov, title="two curves")
    assert re.findall(r'<section class="curve" id="(curve-\d)">', page) == ["curve-1", "curve-2"]
    assert 'id="verdict-1"' in page and 'id="verdict-2"' in page
    assert page.count('<table class="models">') == 2 and page.count('id="provenance-table"') == 1
    assert len(_rows(page)) == 2 * len(diagnosis_page._models(diag))
    assert page.count("data:image/png;base64,") == 3  # the second curve given without figures
    assert _embedded(page) == json.loads(json.dumps(prov))


def test_markup_in_a_file_name_or_a_setting_is_escaped(diag, tmp_path):
    m = load_csv(CLEAN)
    odd = measurement_from_arrays(m.depth_mm, m.force_mN, m.time_s, source=MARKUP)
    context = page_context(diag)
    context.update(source=odd.source, name=odd.source, sentence=SCRIPT)
    prov = provenance(["skin-indent", "diagnose", MARKUP], inputs=[tmp_path / "missing.csv"],
                      settings={"note": SCRIPT})
    page = render_page([context], prov)
    assert "<img src=x" not in page and "<script>alert" not in page
    assert "&lt;img src=x onerror=&#34;alert(1)&#34;&gt;" in page
    assert page.count("</script>") == 1  # the provenance element's own end tag
    assert _embedded(page) == prov  # the record reads back whole


# ------------------------------------------------------------------ the surfaces in the provenance
def test_the_diagnosis_provenance_names_every_surface_its_fits_used(gallery_cache, hidden, diagnosis_surfaces,
                                                                    monkeypatch, tmp_path):
    from skin_indent.diagnosis import workflow

    made, real = [], workflow.Fitter  # the diagnosis' fits, caught as it makes them (a Diagnosis holds no Fitter)
    monkeypatch.setattr(workflow, "Fitter", lambda *a, **k: made.append(real(*a, **k)) or made[-1])
    diag = diagnose(hidden["v01_clean"], candidates=("offset", "stiffening"), max_rungs=0, in_loop=False,
                    cache_dir=gallery_cache, mesh="coarse", workers=1, progress=False)
    cores = made[0].cores
    assert {type(c).__name__ for c in cores} == {"ResponseSurface", "EffectSurface"}
    recorded = diag.to_dict()["provenance"]["surface"]
    assert recorded == surface_identity(cores) and len(recorded) == len(cores)
    for core, ident in zip(cores, recorded):
        if hasattr(core, "axes"):  # an effect surface: the hash of its sub-surfaces, in node order
            parts = [s.hash for s in core.surfaces.flat]
            expected = hashlib.sha256(b"".join(h.encode() + b"\0" for h in parts)).hexdigest()
            assert ident["hash"] == expected and ident["surfaces"] == len(parts)
            assert ident["settings"]["model"] == "neo-hooke+stiffening" and ident["settings"]["mesh"] == "coarse"
            assert ident["axes"] == {a.name: list(a.nodes) for a in core.axes}
        else:
            assert ident["hash"] == core.hash and ident["settings"] == core.settings
    page = write_report(diag, tmp_path).read_text()
    (surfaces,) = [v for k, v in provenance_rows(diag.provenance) if k == "surfaces"]
    assert len(surfaces) == len(cores) and all(f"hash {s['hash'][:12]}" in page for s in recorded)
    assert read_provenance(tmp_path / "ladder.png")["surface"] == recorded


def test_the_finite_elements_in_the_loop_are_named_by_what_their_runs_solve():
    core = FECore(("layer", "layer"), radius_mm=6.22, max_depth_mm=0.6, e_star_kPa=10.0, mesh="coarse")
    ident = surface_identity(core)
    assert ident["hash"] is None and ident["type"] == "FECore"
    assert ident["settings"] == {"model": "neo-hooke+layer+layer", "mesh": "coarse", "radius_mm": 6.22,
                                 "depth_range_mm": list(core.depth_range)}
    rows = dict(provenance_rows(provenance(["x"], surface=[core])))
    assert rows["surfaces"] == ["FECore neo-hooke+layer+layer (mesh coarse, R = 6.22 mm): its runs made during "
                                "the fit"]


def test_diagnose_json_and_page_name_the_surfaces(gallery_cache, diagnosis_surfaces, monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("SKIN_INDENT_CACHE", str(gallery_cache))
    argv = ["diagnose", str(CLEAN), "--candidates", "offset,stiffening", "--max-rungs", "0", "--surfaces-only",
            "--mesh", "coarse", "--json", "-q", "--report", str(tmp_path / "report")]
    assert main(argv) == 0
    prov = json.loads(capsys.readouterr().out)["provenance"]
    kinds = {s["type"]: s for s in prov["surface"]}
    assert set(kinds) == {"ResponseSurface", "EffectSurface"}
    assert all(re.fullmatch(r"[0-9a-f]{64}", s["hash"]) for s in prov["surface"])
    page = (tmp_path / "report" / "index.html").read_text()
    assert _embedded(page) == prov
    assert f"EffectSurface neo-hooke+stiffening (mesh coarse, R = 6.22 mm): hash {kinds['EffectSurface']['hash'][:12]}" \
        in page
