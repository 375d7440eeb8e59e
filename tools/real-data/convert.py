"""Convert a JPK force curve (afmformats' test data, MIT) into tests/data/real-data: CSV + PNG.

Usage (afmformats 0.18.7 from PyPI, numpy, matplotlib)::

    git -C /path/to/afmformats show HEAD:tests/data/fmt-jpk-fd_spot3-0192.jpk-force > /tmp/x.jpk-force
    python tools/real-data/convert.py /tmp/x.jpk-force tests/data/real-data/jpk_fd_spot3_Runknown --index 0

Conventions (tests/data/real-data/README.md): columns ``time_s,depth_mm,force_mN``; the tip position is
``height (measured)`` + force / k (k the spring constant stored in the file), depth = -(tip - tip[0]) in mm;
force is afmformats' calibrated force (N -> mN x 1e3) with nothing removed; rows in time order, values
written as round-trip float64. The PNG shows force against depth and against time, segments coloured, the
median baseline of the first 40 % of the approach dashed and the rough contact estimate (the last approach
sample below baseline + 8 baseline sd) dotted. The script prints what the README's table needs.
"""

from __future__ import annotations

import argparse
import hashlib
from pathlib import Path

import numpy as np

#: afmformats' segment numbers of a force-distance curve (with a hold: approach, hold, retract)
KINDS = {2: ("approach", "retract"), 3: ("approach", "hold", "retract")}


def convert(path: Path, out: Path, index: int = 0) -> dict:
    """Write ``out``.csv and ``out``.png from curve ``index`` of the JPK file ``path``; returns its facts."""
    import afmformats

    d = afmformats.load_data(str(path))[index]
    k = float(d.metadata["spring constant"])
    force = np.asarray(d["force"], dtype=float)
    tip = np.asarray(d["height (measured)"], dtype=float) + force / k
    time = np.asarray(d["time"], dtype=float)
    seg = np.asarray(d["segment"], dtype=int)
    depth_mm = -(tip - tip[0]) * 1e3
    force_mN = force * 1e3
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out.with_suffix(".csv"), "w") as fh:
        fh.write("time_s,depth_mm,force_mN\n")
        for row in zip(time - time[0], depth_mm, force_mN):
            fh.write(",".join(repr(float(v)) for v in row) + "\n")
    approach = seg == seg.min()
    n40 = max(5, int(0.4 * np.count_nonzero(approach)))
    base = float(np.median(force_mN[approach][:n40]))
    sd = float(np.std(force_mN[approach][:n40]))
    below = np.flatnonzero(approach & (force_mN < base + 8 * sd))
    contact = float(depth_mm[below[-1]]) if below.size else float("nan")
    starts = [int(np.flatnonzero(seg == s)[0]) for s in np.unique(seg)]
    facts = {"file": out.with_suffix(".csv").name, "sha256_16": hashlib.sha256(path.read_bytes()).hexdigest()[:16],
             "k_N_per_m": k, "segment_rows": starts, "segment_t_s": [float(time[i] - time[0]) for i in starts],
             "end_t_s": float(time[-1] - time[0]),
             "speeds_um_s": tuple(d.metadata.get(f"speed {k}", np.nan) * 1e6 for k in ("approach", "retract")),
             "rate_Hz": d.metadata.get("rate approach"), "baseline_mN": base, "noise_mN": sd,
             "contact_mm": contact, "max_depth_beyond_mm": float(depth_mm[approach].max() - contact),
             "peak_above_baseline_mN": float(force_mN.max() - base),
             "min_below_baseline_mN": float(force_mN.min() - base),
             "instrument": d.metadata.get("instrument"), "date": str(d.metadata.get("date")),
             "mode": d.metadata.get("imaging mode")}
    _figure(out.with_suffix(".png"), time - time[0], depth_mm, force_mN, seg, base, contact)
    return facts


def _figure(png: Path, t, depth_mm, force_mN, seg, base, contact) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = KINDS.get(len(np.unique(seg)), tuple(f"segment {s}" for s in np.unique(seg)))
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for s, name in zip(np.unique(seg), names):
        sel = seg == s
        a.plot(depth_mm[sel] * 1e3, force_mN[sel] * 1e6, ".", ms=1, label=name)
        b.plot(t[sel], force_mN[sel] * 1e6, ".", ms=1, label=name)
    for ax in (a, b):
        ax.axhline(base * 1e6, ls="--", c="k", lw=0.8)
        ax.set_ylabel("force (nN)")
    a.axvline(contact * 1e3, ls=":", c="k", lw=0.8)
    a.set_xlabel("depth (um)")
    b.set_xlabel("time (s)")
    a.legend(markerscale=8)
    a.set_title(png.stem, fontsize=9)
    fig.tight_layout()
    fig.savefig(png, dpi=90)
    plt.close(fig)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("source", type=Path, help="a JPK .jpk-force or .jpk-force-map file")
    p.add_argument("out", type=Path, help="output path without suffix (CSV and PNG are written)")
    p.add_argument("--index", type=int, default=0, help="the curve of a force map (from 0)")
    args = p.parse_args(argv)
    for k, v in convert(args.source, args.out, args.index).items():
        print(f"{k}: {v}")


if __name__ == "__main__":
    main()
