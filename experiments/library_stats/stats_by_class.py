"""Roughness and specular F0 per material class of the library, beside the real reference per category.

Which classes pull the library's roughness and specular away from real materials? The library: every preset's
``--per-preset`` variants at ``--size``² (seed 0, the default sigma), the store bench_realism.py profiles. The
reference: the folder of real materials (default ``../shared/materials-cc0`` beside the repository root) imported
at ``--size``²; each material's category is read from the folder's README table (``| asset | category | ...``),
since the folders carry no metadata.json. Both go through :func:`pipeline.stats.profile.profile`, so the values
are exactly the pixel samples (64² grid per material) that ``svgen stats --reference`` compares.

Per statistic (roughness, specular F0 luminance; and the per-material CV of specular Y and of the slope magnitude, one
value per material) and per class / category: materials, mean, 10/25/50/75/90 %
quantiles of the pooled pixel values; per class also

* ``w_alone``: 1-D Wasserstein distance from the class's pixels alone to the whole reference;
* ``w_without_delta``: the library's distance to the reference without the class minus with it (positive: the
  class pulls the library AWAY from the reference; removing it would bring the library closer).

Plus every preset's mean roughness and specular (over its variants) so that an offending class's presets can be
found. Writes experiments/library_stats/results/stats_by_class.json (or ``--out``) and prints a markdown table.

Usage: python3 experiments/library_stats/stats_by_class.py [REFERENCE_DIR] [--per-preset 4] [--size 256] [--out FILE]
"""
from __future__ import annotations

import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.stats import wasserstein_distance

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import ROOT, parser, write_results  # noqa: E402

#: this experiment's frozen results (experiments/library_stats/results/)
RESULTS = Path(__file__).resolve().parent / "results"

DEFAULT_REFERENCE = ROOT.parent / "shared" / "materials-cc0"
#: pixel statistics (pooled pixel values) and per-material ones (one value per material: svgen stats compares those
#: distributions, e.g. how much specular varies within a material)
PIXEL_STATS = ("roughness", "specular_f0")
MATERIAL_STATS = ("cv_specular", "cv_relief")
STATS = PIXEL_STATS + MATERIAL_STATS
QUANTILES = (10, 25, 50, 75, 90)


def reference_categories(ref_dir: Path) -> dict[str, str]:
    """asset name -> category from the reference folder's README table (empty when there is no README).

    Args:
        ref_dir: folder holding README.md with rows ``| asset | category | ...``.
    """
    readme = ref_dir / "README.md"
    if not readme.is_file():
        return {}
    row = re.compile(r"^\|\s*([^|\s]+)\s*\|\s*([a-z_-]+)\s*\|")
    return {m.group(1): m.group(2) for line in readme.read_text().splitlines()
            if (m := row.match(line)) and m.group(1) not in ("asset", "---")}


def summary(x: np.ndarray) -> dict:
    """Mean and quantiles of pooled pixel values ``x`` (any shape)."""
    x = np.asarray(x, np.float64).ravel()
    return {"mean": round(float(x.mean()), 4),
            **{f"p{q}": round(float(v), 4) for q, v in zip(QUANTILES, np.percentile(x, QUANTILES))}}


def by_group(pixels: dict[str, np.ndarray], groups: list[str], ref: dict[str, np.ndarray] | None = None) -> dict:
    """statistic -> group -> summary (plus, given the reference's pixels, the Wasserstein columns).

    Args:
        pixels: statistic -> (M, P) pixel values of M materials (P = 1 for a per-material statistic).
        groups: (M,) group (class or category) of every material.
        ref: statistic -> (R, P) reference pixels, or None for the reference itself.
    """
    g = np.asarray(groups)
    out = {}
    for s in STATS:
        full = None if ref is None else wasserstein_distance(pixels[s].ravel(), ref[s].ravel())
        out[s] = {}
        for c in sorted(set(groups)):
            row = {"materials": int((g == c).sum()), **summary(pixels[s][g == c])}
            if ref is not None:
                rest = pixels[s][g != c].ravel()
                row["w_alone"] = round(float(wasserstein_distance(pixels[s][g == c].ravel(), ref[s].ravel())), 4)
                row["w_without_delta"] = round(full - float(wasserstein_distance(rest, ref[s].ravel())), 4)
            out[s][c] = row
        if full is not None:
            out[s]["_all"] = {"materials": len(groups), **summary(pixels[s]), "w_alone": round(float(full), 4)}
    return out


def values(p) -> dict[str, np.ndarray]:
    """statistic -> (M, P) values of a profile: pixel statistics as sampled, per-material ones as (M, 1)."""
    return {**{s: p.pixels[s] for s in PIXEL_STATS},
            **{s: np.asarray(p.per_material[s])[:, None] for s in MATERIAL_STATS}}


def table(res: dict) -> str:
    """Markdown: per statistic, the library's classes then the reference's categories."""
    lines = []
    for s in STATS:
        lines += ["", f"### {s}", "", "| group | n | mean | p10 | p25 | p50 | p75 | p90 | W alone | W pull |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for side, rows in (("", res["library"][s]), ("ref ", res["reference"][s])):
            for c, r in rows.items():
                lines.append(f"| {side}{c} | {r['materials']} | " + " | ".join(
                    f"{r[k]:.3f}" for k in ("mean", *(f"p{q}" for q in QUANTILES)))
                    + f" | {r.get('w_alone', float('nan')):.3f} | {r.get('w_without_delta', float('nan')):+.3f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("reference", nargs="?", default=str(DEFAULT_REFERENCE),
                    help="folder of real material folders [default: ../shared/materials-cc0 beside the repository]")
    ap.add_argument("--per-preset", type=int, default=4, help="variants of every base material in the library")
    ap.add_argument("--size", type=int, default=256, help="map side of the library and of the imported reference")
    ap.add_argument("--out", default=str(RESULTS / "stats_by_class.json"))
    a = ap.parse_args(argv)
    ref_dir = Path(a.reference)
    if not ref_dir.is_dir():
        print(f"stats_by_class: no reference folder at {ref_dir} (pass the folder of real materials)",
              file=sys.stderr)
        return 2

    from pipeline.config import ImportConfig, SampleConfig
    from pipeline.importer.job import run_import
    from pipeline.sample import run_sample
    from pipeline.stats.profile import profile
    from storage.svbrdf_store import SVBRDFStore
    from svcore.config import build

    cats = reference_categories(ref_dir)
    tmp = Path(tempfile.mkdtemp(prefix="stats-by-class-"))
    try:
        ref_store, _ = run_import(tmp / "reference.zarr", build(ImportConfig, sources=(str(ref_dir),), size=a.size),
                                  workers=0)
        lib = run_sample(tmp / "library.zarr", build(SampleConfig, per_preset=a.per_preset, size=a.size, seed=0),
                         workers=0)
        rp, lp = profile(ref_store), profile(lib)
        rpix, lpix = (values(p) for p in (rp, lp))
        rs, ls = SVBRDFStore(ref_store), SVBRDFStore(lib)
        ref_names = [rs.source(i)["presets"][0].split("/", 1)[1] for i in range(len(rs))]
        presets = [ls.source(i)["presets"][0] for i in range(len(ls))]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    ref_cats = [cats.get(n, "unknown") for n in ref_names]
    classes = [p.split("/")[0] for p in presets]
    per_preset = {}
    for p in sorted(set(presets)):
        i = [k for k, q in enumerate(presets) if q == p]
        per_preset[p] = {s: round(float(lpix[s][i].mean()), 3) for s in STATS}
    res = {"reference_folder": os.path.relpath(ref_dir.resolve(), ROOT),
           "library_config": {"config": "default", "per_preset": a.per_preset, "size": a.size, "seed": 0},
           "reference_materials": dict(zip(ref_names, ref_cats)),
           "columns": {"w_alone": "Wasserstein-1 from the class's pixels alone to the whole reference",
                       "w_without_delta": "the library's distance to the reference minus its distance without "
                                          "the class (positive: the class pulls the library away)"}}
    res["library"] = by_group(lpix, classes, rpix)
    res["reference"] = by_group(rpix, ref_cats)
    res["reference"] = {s: {**res["reference"][s], "_all": {"materials": len(ref_cats), **summary(rpix[s])}}
                        for s in STATS}
    res["per_preset_mean"] = per_preset
    write_results(a.out, res, note=a.note)
    print(table(res))
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
