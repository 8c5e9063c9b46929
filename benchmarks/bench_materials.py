"""Material generation throughput: variants per second at 256², single process and 2 processes.

A *variant* is ``preset.generate(params, 256, seed)`` with every exposed parameter drawn uniformly in
its range (what `svgen sample` does per variant, minus the store write). Variants cycle over all
presets, so the figure is the library average. The pool is started and warmed before timing; workers
return a checksum, not the maps (the real stage writes maps from the worker).

Bar (issue #2): >= 15 variants/s on 2 cores, i.e. the paper's 1,850 variants in <= 2 minutes.

Writes benchmarks/results/materials.json. Usage: python3 benchmarks/bench_materials.py [--rounds N]
"""
from __future__ import annotations

import json
import multiprocessing as mp
import os
import time

import numpy as np

from materials import presets
from materials.catalog import stats

from harness import RESULTS, parser, write_results

SIZE = 256
BAR = 15.0


def variant(i: int) -> float:
    """Generate variant ``i`` (preset i mod n, perturbed params from seed i); returns a checksum."""
    ps = presets()
    p = ps[i % len(ps)]
    rng = np.random.default_rng(i)
    params = {q.name: float(rng.uniform(q.low, q.high)) for q in p.exposed}
    m = p.generate(params, SIZE, i)
    return float(m.diffuse[0, 0, 0] + m.roughness[-1, -1, 0])


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--rounds", type=int, default=3, help="passes over all presets per measurement")
    ap.add_argument("--out", default=str(RESULTS / "materials.json"))
    a = ap.parse_args(argv)
    n_pre = len(presets())
    n = a.rounds * n_pre
    for i in range(n_pre):  # warm-up: imports, caches
        variant(i)
    per_class: dict[str, list[float]] = {}
    t0 = time.perf_counter()
    for i in range(n):
        t = time.perf_counter()
        variant(i)
        per_class.setdefault(presets()[i % n_pre].cls, []).append(time.perf_counter() - t)
    single = n / (time.perf_counter() - t0)
    ctx = mp.get_context("fork" if hasattr(os, "fork") else "spawn")
    with ctx.Pool(2) as pool:
        pool.map(variant, range(n_pre), chunksize=4)  # warm both workers
        t0 = time.perf_counter()
        pool.map(variant, range(n, 2 * n), chunksize=4)
        two = n / (time.perf_counter() - t0)
    s = stats()
    res = {
        "classes": s["classes"], "base_materials": s["base_materials"], "mean_params": round(s["mean_params"], 3),
        "min_params": s["min_params"], "max_params": s["max_params"],
        "size": SIZE, "variants_timed": n,
        "variants_per_s": round(two, 2), "variants_per_s_2proc": round(two, 2),
        "variants_per_s_1proc": round(single, 2),
        "bar_variants_per_s": BAR, "passes_bar": bool(two >= BAR),
        "paper_1850_variants_s": round(1850 / two, 1),
        "ms_per_variant_by_class_1proc": {k: round(1000 * float(np.mean(v)), 1) for k, v in sorted(per_class.items())},
    }
    write_results(a.out, res, a.note)
    print(json.dumps(res, indent=2))
    return res


if __name__ == "__main__":
    main()
