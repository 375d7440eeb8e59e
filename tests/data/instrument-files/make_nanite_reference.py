"""Regenerate nanite_reference.json: nanite's own Hertz fits of the curves in this folder.

RUN ONLY IN A SEPARATE VIRTUAL ENVIRONMENT WITH NANITE, never from skin_indent:

    python -m venv /tmp/nanite-venv
    /tmp/nanite-venv/bin/pip install nanite==4.2.3   # pulls afmformats 0.18.7, lmfit 1.3.4
    /tmp/nanite-venv/bin/python tests/data/instrument-files/make_nanite_reference.py

nanite is GPL-3 licensed: skin_indent does not import it and contains none of its
code. This script only calls nanite's public API (``IndentationGroup``,
``apply_preprocessing``, ``fit_model``) and writes the numbers it returns, so that
skin_indent's tests can compare its own Hertz fits with a peer implementation
without nanite installed.

What is recorded, per file and curve, for each named setting (see SETTINGS):
the radius and Poisson ratio used, the model key, the preprocessing steps, the
contact-point weighting, the fitted E (Pa), the contact point (m, in nanite's
tip-position axis after its preprocessing, and converted to skin_indent's depth
axis in mm), the fitted baseline and the force offset nanite's preprocessing
removed (N), the fit range and the number of fitted points.

skin_indent's depth axis: depth_mm = -(tip - tip[0]) * 1e3, with tip = nanite's
"tip position" after ``compute_tip_position`` only (height (measured) + force/k,
or the Chiaro file's own tip position) and tip[0] its first sample. nanite's
``correct_tip_offset`` subtracts a constant (its first contact estimate); the
script measures that constant and undoes it for the converted values.
"""

import hashlib
import json
import pathlib
import platform
import sys

import afmformats
import lmfit
import nanite
import numpy as np
from nanite import IndentationGroup
from nanite.model import get_init_parms

HERE = pathlib.Path(__file__).resolve().parent
OUT = HERE / "nanite_reference.json"

PREPROCESSING = ["compute_tip_position", "correct_force_offset", "correct_tip_offset"]

#: file -> (radius in m, where the radius comes from, curve indices)
CURVES = {
    "force-save-example.jpk-force": (
        18.64e-6, "nanite's fitting guide (docs/sec_fitting_guide.rst) for this file", [0]),
    "fmt-jpk-fd_map-data-reference-points.jpk-force-map": (
        37.28e-6 / 2, "nanite's tests/test_qmap.py for this file (R = 37.28e-6 / 2)", [0, 1, 2]),
    "fmt-jpk-fd_spot3-0192.jpk-force": (
        10e-6, "not recorded; nanite's default R of sneddon_spher_approx/hertz_para (assumed)", [0]),
    "fmt-chiaro-txt_AEBP1_Indentation_002.txt": (
        27.5e-6, "the file header (Tip radius (um) 27.500)", [0]),
}

COMMON = dict(range_x=(0, 0), range_type="absolute", x_axis="tip position", y_axis="force",
              segment=0)  # segment 0 = approach; range (0, 0) = the whole approach

#: name -> (description, model_key, weight_cp, baseline varies?, initial E in Pa or None)
SETTINGS = {
    "hertz_unweighted": (
        "Hertz paraboloid (pure Hertz, F = 4/3 E/(1-nu^2) sqrt(R) d^1.5), no contact-point "
        "weighting, baseline free", "hertz_para", False, True, None),
    "hertz_unweighted_baseline_fixed": (
        "as hertz_unweighted, baseline fixed at 0 after correct_force_offset",
        "hertz_para", False, False, None),
    "sneddon_unweighted": (
        "nanite's default spherical model (Sneddon, truncated series), no contact-point "
        "weighting, baseline free", "sneddon_spher_approx", False, True, None),
    "sneddon_unweighted_baseline_fixed": (
        "as sneddon_unweighted, baseline fixed at 0 after correct_force_offset",
        "sneddon_spher_approx", False, False, None),
    "nanite_defaults": (
        "nanite's defaults (nanite-fit CLI profile: sneddon_spher_approx, weight_cp = 5e-7, "
        "baseline free)", "sneddon_spher_approx", 5e-7, True, None),
    "hertz_nanite_default_weight": (
        "Hertz paraboloid with nanite's default weight_cp = 5e-7, baseline free",
        "hertz_para", 5e-7, True, None),
    "nanite_test": (
        "nanite's tests/test_qmap.py settings: sneddon_spher_approx, weight_cp = 2e-6, "
        "baseline fixed at 0, initial E = 50 Pa", "sneddon_spher_approx", 2e-6, False, 50.0),
}


def sha256(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def load(path, index):
    """A fresh nanite Indentation (no fit state carried between settings)."""
    return IndentationGroup(path)[index]


def fit(path, index, radius, setting):
    _, model_key, weight_cp, baseline_varies, e_init = SETTINGS[setting]
    raw = load(path, index)
    raw.apply_preprocessing(["compute_tip_position"])
    tip_raw = np.array(raw["tip position"], dtype=float)
    force_raw = np.array(raw["force"], dtype=float)

    idnt = load(path, index)
    idnt.apply_preprocessing(PREPROCESSING)
    tip_offset = float(np.median(tip_raw - np.array(idnt["tip position"])))
    force_offset = float(np.median(force_raw - np.array(idnt["force"])))
    params = get_init_parms(model_key)
    params["R"].value = radius
    params["baseline"].vary = baseline_varies
    if e_init is not None:
        params["E"].value = e_init
    idnt.fit_model(model_key=model_key, params_initial=params, weight_cp=weight_cp, **COMMON)
    fp = idnt.fit_properties
    fitted = fp["params_fitted"]
    in_range = np.asarray(idnt["fit range"], dtype=bool)

    def depth_mm(tip):  # nanite's preprocessed tip position -> skin_indent depth (mm)
        return -((tip + tip_offset) - tip_raw[0]) * 1e3 + 0.0  # + 0.0: no "-0.0" in the JSON

    cp = float(fitted["contact_point"].value)
    stderr = fitted["E"].stderr
    return {
        "model_key": model_key,
        "weight_cp": weight_cp,
        "baseline_varies": baseline_varies,
        "E_Pa": float(fitted["E"].value),
        "E_stderr_Pa": None if stderr is None else float(stderr),
        "contact_point_m": cp,
        "contact_point_depth_mm": depth_mm(cp),
        "baseline_N": float(fitted["baseline"].value),
        "force_offset_removed_N": force_offset,
        "tip_offset_removed_m": tip_offset,
        "fit_range_m": [float(fp["xmin"]), float(fp["xmax"])],
        "fit_range_depth_mm": sorted([depth_mm(float(fp["xmin"])), depth_mm(float(fp["xmax"]))]),
        "n_fit_points": int(in_range.sum()),
        "chi_sqr": float(fp["chi_sqr"]),
        "success": bool(fp["success"]),
    }


def main():
    curves = []
    for name, (radius, radius_source, indices) in CURVES.items():
        path = HERE / name
        n_curves = len(IndentationGroup(path))
        for index in indices:
            meta = load(path, index).metadata
            entry = {"file": name, "sha256": sha256(path), "index": index, "n_curves": n_curves,
                     "enum": int(meta["enum"]) if "enum" in meta else None,
                     "radius_m": radius, "radius_um": radius * 1e6, "radius_source": radius_source,
                     "nu": 0.5, "results": {}}
            for setting in SETTINGS:
                entry["results"][setting] = fit(path, index, radius, setting)
                r = entry["results"][setting]
                print(f"{name}[{index}] {setting:34s} E = {r['E_Pa']:10.2f} Pa  "
                      f"cp depth = {r['contact_point_depth_mm']:.6f} mm", file=sys.stderr)
            curves.append(entry)
    out = {
        "about": "nanite's Hertz fits of the curves in this folder; regenerate with "
                 "make_nanite_reference.py in a separate venv (nanite is GPL-3, never imported "
                 "by skin_indent)",
        "versions": {"nanite": nanite.__version__, "afmformats": afmformats.__version__,
                     "lmfit": lmfit.__version__, "numpy": np.__version__,
                     "python": platform.python_version()},
        "units": {"E_Pa": "Pa", "radius_m": "m", "contact_point_m": "m (nanite tip position "
                  "after preprocessing; negative = further into the sample)",
                  "contact_point_depth_mm": "mm, skin_indent depth axis (see conventions)",
                  "baseline_N": "N", "force_offset_removed_N": "N", "fit_range_m": "m",
                  "fit_range_depth_mm": "mm"},
        "conventions": "skin_indent depth_mm = -(tip - tip[0]) * 1e3 with tip = nanite's tip "
                       "position after compute_tip_position only; nanite's correct_tip_offset "
                       "shift (tip_offset_removed_m) is undone for the *_depth_mm values. Force "
                       "in the raw file = nanite's force + force_offset_removed_N, so the "
                       "baseline in raw force is force_offset_removed_N + baseline_N.",
        "preprocessing": PREPROCESSING,
        "fit_common": {k: list(v) if isinstance(v, tuple) else v for k, v in COMMON.items()},
        "poisson_ratio": "nu = 0.5 fixed (nanite's default) in every fit; R fixed",
        "settings": {k: {"description": d, "model_key": m, "weight_cp": w, "baseline_varies": b,
                         "initial_E_Pa": e if e is not None else "nanite default (3000)"}
                     for k, (d, m, w, b, e) in SETTINGS.items()},
        "curves": curves,
    }
    OUT.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {OUT}", file=sys.stderr)


if __name__ == "__main__":
    main()
