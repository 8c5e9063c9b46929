"""Per-preset generation time at 256², single-threaded: CPU milliseconds of ``preset.generate(None, 256, seed)``.

CPU time (``time.process_time``) rather than wall time, so a busy shared machine slows the figure less (cache and
memory-bandwidth contention still count); the median over ``--reps`` seeds after one warm-up call. Issue #23 asks
about 20-30 ms per preset (>= 50 variants/s on 2 cores). Run with OMP_NUM_THREADS=1.

Writes experiments/preset_speed/results/presets_<classes>.json. Usage:
python3 experiments/preset_speed/bench_presets.py --classes bricks,roofing,concrete,rock [--reps 5]
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from materials import presets

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

#: this experiment's frozen results (experiments/preset_speed/results/)
RESULTS = Path(__file__).resolve().parent / "results"

SIZE = 256


def preset_ms(p, reps: int) -> float:
    """Median CPU ms of one generation of preset ``p`` at ``SIZE``² over ``reps`` seeds (after a warm-up)."""
    p.generate(None, SIZE, 0)
    ts = []
    for s in range(reps):
        t = time.process_time()
        p.generate(None, SIZE, s)
        ts.append(time.process_time() - t)
    return 1000 * float(np.median(ts))


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--classes", required=True, help="comma-separated material classes")
    ap.add_argument("--reps", type=int, default=5, help="timed generations per preset")
    ap.add_argument("--out", default=None, help="results JSON [results/presets_<classes>.json]")
    a = ap.parse_args(argv)
    classes = [c.strip() for c in a.classes.split(",") if c.strip()]
    per = {p.name: round(preset_ms(p, a.reps), 1) for c in classes for p in presets(c)}
    res = {"size": SIZE, "reps": a.reps, "classes": classes, "presets": len(per),
           "ms_cpu_median_by_preset": per,
           "ms_cpu_mean_over_presets": round(float(np.mean(list(per.values()))), 1),
           "ms_cpu_max_over_presets": max(per.values())}
    write_results(a.out or RESULTS / f"presets_{'_'.join(classes)}.json", res, a.note)
    print(json.dumps(res, indent=1))
    return res


if __name__ == "__main__":
    main()
