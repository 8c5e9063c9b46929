"""Material generation throughput: variants per second at 256², single process and 2 processes.

A *variant* is ``preset.generate(params, 256, seed)`` with every exposed parameter drawn uniformly in
its range (what `svgen sample` does per variant, minus the store write). Variants cycle over all
presets, so the figure is the library average. The pool is started and warmed before timing; workers
return a checksum, not the maps (the real stage writes maps from the worker).

Bar (issue #2): >= 15 variants/s on 2 cores, i.e. the paper's 1,850 variants in <= 2 minutes.

Writes benchmarks/results/materials.json. Usage: python3 benchmarks/bench_materials.py [--rounds N]

``--against CHECKOUT`` adds ``same_machine_ab``: one pass over every preset in a fresh single process with
CHECKOUT's code and with this checkout's, alternating, ``--ab-rounds`` times (this VM's speed drifts between days
and within minutes, so a figure against a record from another day says little about the code).
"""
from __future__ import annotations

import json
import multiprocessing as mp
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from materials import presets
from materials.catalog import stats

from harness import RESULTS, ROOT, parser, write_results

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


#: one pass of :func:`variant` over every preset in a fresh process, printing variants per CPU second (run with a
#: checkout's code: the same generation call in any version that has ``materials.presets``)
_ONE_PASS = """
import time, numpy as np
from materials import presets
ps = presets()
t = time.process_time()
for i, p in enumerate(ps):
    rng = np.random.default_rng(i)
    p.generate({q.name: float(rng.uniform(q.low, q.high)) for q in p.exposed}, %d, i)
print(len(ps) / (time.process_time() - t))
""" % SIZE


def same_machine_ab(against: Path, rounds: int) -> dict:
    """Single-process variants per CPU second of ``against``'s code and this checkout's, interleaved."""
    runs: dict[str, list[float]] = {"against": [], "this": []}
    for _ in range(rounds):
        for label, where in (("against", against), ("this", ROOT)):
            env = {**os.environ, "PYTHONPATH": str(where)}
            r = subprocess.run([sys.executable, "-c", _ONE_PASS], cwd=where, env=env, capture_output=True, text=True,
                               check=True)
            runs[label].append(round(float(r.stdout.strip().splitlines()[-1]), 1))
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=against, capture_output=True, text=True)
    return {"against": f"a checkout of {commit.stdout.strip() or 'unknown commit'}", "rounds": rounds,
            "variants_per_cpu_s_1proc": runs,
            "median": {k: statistics.median(v) for k, v in runs.items()}}


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--rounds", type=int, default=3, help="passes over all presets per measurement")
    ap.add_argument("--against", type=Path, default=None, help="another checkout to compare with, interleaved")
    ap.add_argument("--ab-rounds", type=int, default=9, help="rounds of the --against comparison")
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
    if a.against is not None:
        res["same_machine_ab"] = same_machine_ab(a.against.resolve(), a.ab_rounds)
    write_results(a.out, res, a.note)
    print(json.dumps(res, indent=2))
    return res


if __name__ == "__main__":
    main()
