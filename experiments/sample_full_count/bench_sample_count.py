"""The sample stage's rate at the paper's full count against its quarter, and what its fixed start costs (#42).

`benchmarks/bench_paper_scale.py` measures the stages at a quarter of the paper's counts and projects linearly, so a
stage's one-time start (the local dask cluster's worker processes and their imports) is counted into every
variant: the quarter run's 364 variants per second understate what 1,820 do. This runs `svgen sample --config-preset
paper` (2 workers, each run its own process as a user runs it: benchmarks/harness.run_child) at ``--counts``
variants per base material, alternating the counts over ``--rounds`` rounds, and fits wall = start + n / rate.

    python3 experiments/sample_full_count/bench_sample_count.py   # -> results/sample_count.json
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from harness import SVGEN, run_child  # noqa: E402


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--counts", type=int, nargs="+", default=[2, 10], help="variants per base material")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "sample_count.json"))
    a = ap.parse_args(argv)
    from materials.registry import presets

    bases = len(list(presets()))
    work = Path(tempfile.mkdtemp(prefix="sample_count_"))
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": str(ROOT)}
    runs = {c: [] for c in a.counts}
    try:
        for r in range(a.rounds):
            for c in (a.counts if r % 2 == 0 else a.counts[::-1]):
                out = work / f"v_{c}_{r}.zarr"
                m = run_child([*SVGEN, "sample", str(out), "--config-preset", "paper", "--per-preset", str(c),
                               "--workers", str(a.workers)], env, cwd=str(ROOT))
                runs[c].append({"wall_s": round(m["wall_s"], 3), "cpu_s": round(m["cpu_s"], 3)})
                print(c, r, runs[c][-1], flush=True)
                shutil.rmtree(out)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    n = {c: c * bases for c in a.counts}
    med = {c: {f: statistics.median(x[f] for x in v) for f in ("wall_s", "cpu_s")} for c, v in runs.items()}
    # wall = start + n / rate, fitted through the medians (two counts: the line through them)
    xs, ys = np.array([n[c] for c in a.counts], float), np.array([med[c]["wall_s"] for c in a.counts])
    slope, start = np.polyfit(xs, ys, 1)
    cs = np.array([med[c]["cpu_s"] for c in a.counts])
    cslope, cstart = np.polyfit(xs, cs, 1)
    res = {"experiment": "sample_full_count", "base_materials": bases, "workers": a.workers, "runs": runs,
           "median": {str(c): med[c] for c in a.counts},
           "variants_per_s": {str(c): round(n[c] / med[c]["wall_s"], 1) for c in a.counts},
           "fit": {"start_wall_s": round(float(start), 2), "marginal_variants_per_s": round(1 / float(slope), 1),
                   "start_cpu_s": round(float(cstart), 2), "cpu_ms_per_variant": round(1000 * float(cslope), 1)},
           "note": a.note,
           "command": "python3 experiments/sample_full_count/bench_sample_count.py " + " ".join(argv or sys.argv[1:])}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps({k: res[k] for k in ("variants_per_s", "fit")}))
    return res


if __name__ == "__main__":
    main()
