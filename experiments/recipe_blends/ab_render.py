"""What reading a recipe blends store costs the render: the same blends rendered from a recipe store and from a
stored-maps store, rounds interleaved on one machine in one state (#42).

Makes a variants store (``--per-preset`` of every preset at ``--size``) and ``--count`` blends of it twice
(``--maps recipe`` and ``--maps stored``), then renders each ``--rounds`` times (``svgen render BLENDS OUT``, the
blends only, ``--views`` views at ``--res``, 2 workers), alternating, each as a user runs it (its own process:
wall and CPU of the process tree, benchmarks/harness.run_child). Checks that the two renders are the same arrays.

    python3 experiments/recipe_blends/ab_render.py   # -> experiments/recipe_blends/results/ab_render.json
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
import zarr

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from harness import SVGEN, run_child  # noqa: E402


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--per-preset", type=int, default=1)
    ap.add_argument("--size", type=int, default=288)
    ap.add_argument("--count", type=int, default=256)
    ap.add_argument("--views", type=int, default=10)
    ap.add_argument("--res", type=int, default=288)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "ab_render.json"))
    a = ap.parse_args(argv)
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": str(ROOT)}
    work = Path(tempfile.mkdtemp(prefix="ab_render_"))
    try:
        v = work / "v.zarr"
        run_child([*SVGEN, "sample", str(v), "--per-preset", str(a.per_preset), "--size", str(a.size),
                   "--workers", "2"], env, cwd=str(ROOT))
        for maps in ("recipe", "stored"):
            run_child([*SVGEN, "blend", str(v), str(work / f"{maps}.zarr"), "--count", str(a.count), "--maps", maps,
                       "--workers", "2"], env, cwd=str(ROOT))
        rounds = {"recipe": [], "stored": []}
        for r in range(a.rounds):
            for maps in ("recipe", "stored") if r % 2 == 0 else ("stored", "recipe"):
                out = work / f"r_{maps}_{r}.zarr"
                m = run_child([*SVGEN, "render", str(work / f"{maps}.zarr"), str(out), "--views", str(a.views),
                               "--res", str(a.res), "--workers", "2"], env, cwd=str(ROOT), peak_rss=True)
                rounds[maps].append({"wall_s": round(m["wall_s"], 3), "cpu_s": round(m["cpu_s"], 3),
                                     "peak_rss_bytes": m["peak_rss_bytes"]})
        x, y = zarr.open_group(work / "r_recipe_0.zarr", mode="r"), zarr.open_group(work / "r_stored_0.zarr", mode="r")
        same = sorted(x.array_keys()) == sorted(y.array_keys()) and all(
            np.array_equal(x[k][:], y[k][:]) for k in x.array_keys())
    finally:
        shutil.rmtree(work, ignore_errors=True)
    med = {k: {f: statistics.median(r[f] for r in v) for f in ("wall_s", "cpu_s")} for k, v in rounds.items()}
    views = a.count * a.views
    res = {"experiment": "recipe_blends.ab_render", "count": a.count, "views": views, "res": a.res, "size": a.size,
           "variants_per_preset": a.per_preset, "rounds": rounds, "median": med, "same_arrays": bool(same),
           "cpu_ms_per_view": {k: round(1000 * m["cpu_s"] / views, 2) for k, m in med.items()},
           "recipe_over_stored_cpu": round(med["recipe"]["cpu_s"] / med["stored"]["cpu_s"], 4),
           "note": a.note, "command": "python3 experiments/recipe_blends/ab_render.py " + " ".join(argv or sys.argv[1:])}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps({k: res[k] for k in ("cpu_ms_per_view", "recipe_over_stored_cpu", "same_arrays")}))
    return res


if __name__ == "__main__":
    main()
