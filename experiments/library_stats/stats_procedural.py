"""`svgen stats` of the procedural library: the numbers behind the widened specular ranges (docs/IMPORT.md).

Samples every preset (``--per-preset`` variants at ``--size``, seed 0, the default sigma) into a temporary store
and writes the stats summary, plus the specular F0 luminance per class (median, 5-95 % range, mean spatial std),
to experiments/library_stats/results/stats_procedural.json (or ``--out``).

Usage: python3 experiments/library_stats/stats_procedural.py [--per-preset 3] [--size 128] [--out FILE]
"""
from __future__ import annotations

import json
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

from pipeline.config import SampleConfig
from pipeline.sample import run_sample
from pipeline.stats import store_stats
from storage.svbrdf_store import SVBRDFStore
from svcore.config import build

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

#: this experiment's frozen results (experiments/library_stats/results/)
RESULTS = Path(__file__).resolve().parent / "results"


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--per-preset", type=int, default=3)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--out", default=str(RESULTS / "stats_procedural.json"))
    a = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="stats-proc-"))
    try:
        path = run_sample(tmp / "v.zarr", build(SampleConfig, per_preset=a.per_preset, size=a.size), workers=0)
        s = store_stats(path, stride=2)
        classes = [src.split("/")[0] for src in (SVBRDFStore(path).source(i)["presets"][0]
                                                for i in range(s["materials"]))]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    per = s["per_material"]
    by_class = {}
    for c in sorted(set(classes)):
        idx = [i for i, k in enumerate(classes) if k == c]
        y = np.asarray(per["specular_y_mean"])[idx]
        by_class[c] = {"specular_y_median": float(np.median(y)), "specular_y_p05": float(np.percentile(y, 5)),
                       "specular_y_p95": float(np.percentile(y, 95)),
                       "specular_y_spatial_std": float(np.mean(np.asarray(per["specular_y_std"])[idx]))}
    res = {"per_preset": a.per_preset, "size": a.size, "summary": s["summary"], "specular_by_class": by_class}
    write_results(a.out, res, note=a.note)
    print(json.dumps(res, indent=1))
    return res


if __name__ == "__main__":
    main()
