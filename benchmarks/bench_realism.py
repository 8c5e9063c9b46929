"""How real is the data: every realism statistic's distance from today's default library to real CC0 materials.

The library: a variants store sampled with the default config (``--per-preset`` variants of every base material
at ``--size``², seed 0). The reference: the folder of real materials (default ``../shared/materials-cc0`` beside the
repository root) imported with `svgen import` at ``--size``², each whole tile area-averaged down (import has no
crop window yet). Both go through :func:`pipeline.stats.compare.compare`, which is what
``svgen stats LIBRARY --reference REFERENCE`` prints: each statistic's distance (1-D Wasserstein, L1 of octave
shares) beside the reference's split-half noise floor (``--splits`` seeded halvings averaged).

Writes key "statistics" of benchmarks/results/realism.json and the chart docs/img/chart_realism.png. A missing
reference folder is refused in one line (exit 2).

Usage: python3 benchmarks/bench_realism.py [REFERENCE_DIR] [--per-preset 4] [--size 256] [--splits 8] [--seed 0]

A library other than the default (``--set KEY=VALUE``, svgen sample's keys) is an experiment: it is written to a
file of its own (``--out``, required with ``--set``), never over the default's; e.g. experiments/library_stats:

    python3 benchmarks/bench_realism.py --set relief_spread=0.5 --out experiments/x/realism_spread.json
"""
from __future__ import annotations

import os
import shutil
import sys
import tempfile
from pathlib import Path

from harness import IMG, RESULTS, ROOT, parser, timed, update_results

DEFAULT_REFERENCE = ROOT.parent / "shared" / "materials-cc0"
LIBRARY = "svgen default library"


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("reference", nargs="?", default=str(DEFAULT_REFERENCE),
                    help="folder of real material folders [default: ../shared/materials-cc0 beside the repository]")
    ap.add_argument("--per-preset", type=int, default=4, help="variants of every base material in the library")
    ap.add_argument("--size", type=int, default=256, help="map side of the library and of the imported reference")
    ap.add_argument("--splits", type=int, default=8, help="halvings of the reference averaged into the noise floor")
    ap.add_argument("--seed", type=int, default=0, help="seed of the halvings")
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                    help="svgen sample setting of the library (repeatable; as `svgen sample --set`)")
    ap.add_argument("--out", default=None, help="results file [default: benchmarks/results/realism.json; "
                    "required with --set]")
    ap.add_argument("--chart", default=None, help="chart path [default: docs/img/chart_realism.png for the "
                    "default library and file, none otherwise]")
    a = ap.parse_args(argv)
    if a.sets and a.out is None:
        print("bench_realism: a library other than the default (--set) is written to a file of its own: pass --out",
              file=sys.stderr)
        return 2
    if a.out is None:
        a.out = str(RESULTS / "realism.json")
        a.chart = a.chart or str(IMG / "chart_realism.png")
    ref_dir = Path(a.reference)
    if not ref_dir.is_dir():
        print(f"bench_realism: no reference folder at {ref_dir} (pass the folder of real materials)", file=sys.stderr)
        return 2

    from pipeline.config import ImportConfig, SampleConfig
    from pipeline.importer.job import run_import
    from pipeline.stats.realism_chart import chart
    from pipeline.stats.compare import compare, table
    from pipeline.stats.profile import profile
    from pipeline.sample import run_sample
    from svcore.config import build, parse_sets
    from svcore.errors import SvgenError

    try:
        overrides = parse_sets(a.sets)
        lib_cfg = build(SampleConfig, per_preset=a.per_preset, size=a.size, seed=0, **overrides)
    except SvgenError as e:
        print(f"bench_realism: {e}", file=sys.stderr)
        return 2

    tmp = Path(tempfile.mkdtemp(prefix="bench-realism-"))
    try:
        ref_store, mats = run_import(tmp / "reference.zarr", build(ImportConfig, sources=(str(ref_dir),),
                                                                   size=a.size), workers=0)
        lib = run_sample(tmp / "library.zarr", lib_cfg, workers=0)
        t = timed(lambda: compare([profile(lib, name=LIBRARY)], profile(ref_store, name=ref_dir.name),
                                  a.splits, a.seed))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    report = t.result
    res = {"reference_folder": os.path.relpath(ref_dir.resolve(), ROOT),
           "reference_import": {"size": a.size, "window": "whole tile, centre-cropped to a square and area-averaged",
                                "materials": len(mats)},
           "library": {"config": "default", "per_preset": a.per_preset, "size": a.size, "seed": 0,
                       **({"settings": overrides} if overrides else {})},
           "stats_wall_s": round(t.wall_s, 1), "report": report}
    update_results(a.out, "statistics", res, note=a.note)
    if a.chart:
        chart(report, a.chart)  # benchmarks/charts/realism.py redraws it from the JSON
    print(table(report))
    print(f"wrote {a.out}" + (f" and {a.chart}" if a.chart else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
