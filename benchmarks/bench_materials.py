"""Material generation throughput: variants per second at 256², single process and 2 processes.

A *variant* is ``preset.generate(params, 256, seed)`` with every exposed parameter drawn uniformly in
its range (what `svgen sample` does per variant, minus the store write). Variants cycle over all
presets, so the figure is the library average. The pool is started and warmed before timing; workers
return a checksum, not the maps (the real stage writes maps from the worker).

Bar (issue #2): >= 15 variants/s on 2 cores, i.e. the paper's 1,850 variants in <= 2 minutes.

Writes benchmarks/results/materials.json. Usage: python3 benchmarks/bench_materials.py [--rounds N]
"""
from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from materials import presets  # noqa: E402
from materials.catalog import stats  # noqa: E402

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


def _cpu_model() -> str:
    try:
        for ln in Path("/proc/cpuinfo").read_text().splitlines():
            if ln.startswith("model name"):
                return ln.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3, help="passes over all presets per measurement")
    ap.add_argument("--out", default=str(ROOT / "benchmarks/results/materials.json"))
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
        "machine": {"cpu": _cpu_model(), "cpu_count": os.cpu_count(), "python": platform.python_version(),
                    "numpy": np.__version__, "platform": platform.platform(),
                    # other work on the machine slows the figures down: keep the load next to them
                    "loadavg_1min_at_end": round(os.getloadavg()[0], 2)},
        "command": "python3 benchmarks/bench_materials.py" + (f" --rounds {a.rounds}" if a.rounds != 3 else ""),
    }
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=2) + "\n")
    print(json.dumps(res, indent=2))
    return res


if __name__ == "__main__":
    main()
