"""What packing the base maps texel by texel saves the render stage: the same store rendered by the code before
(``--before``, a git worktree of that commit) and by this checkout, rounds interleaved on one machine in one state
(#42).

Makes a variants store (``--per-preset`` of every preset at ``--size``, this checkout's `svgen sample`), then renders
it ``--rounds`` times with each code (``svgen render V OUT``, ``--views`` views at ``--res``, ``--workers``
workers), alternating which goes first, each as a user runs it (its own process: wall and CPU of the process tree,
benchmarks/harness.run_child). Checks that the two renders hold the same arrays.

    python3 experiments/packed_texels/ab_render.py --before 25e5d83   # -> results/ab_render.json
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
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
    ap.add_argument("--before", required=True, help="the commit to compare with (a git worktree is made of it)")
    ap.add_argument("--per-preset", type=int, default=2)
    ap.add_argument("--size", type=int, default=288)
    ap.add_argument("--views", type=int, default=10)
    ap.add_argument("--res", type=int, default=288)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "ab_render.json"))
    a = ap.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="ab_packed_"))
    old = work / "before"
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(old), a.before], check=True,
                   capture_output=True)
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    trees = {"before": old, "after": ROOT}
    try:
        v = work / "v.zarr"
        env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": str(ROOT)}
        run_child([*SVGEN, "sample", str(v), "--per-preset", str(a.per_preset), "--size", str(a.size),
                   "--workers", "2"], env, cwd=str(ROOT))
        n = int(zarr.open_group(v, mode="r")["seed"].shape[0])
        # a warm-up per arm, untimed: each code compiles its kernels into drjit's cache once (the first render of a
        # new kernel pays the LLVM compilation; the stage's later runs do not)
        w = work / "w.zarr"
        run_child([*SVGEN, "sample", str(w), "--per-preset", "1", "--size", str(a.size), "--workers", "0",
                   "--preset", "wood/oak_planks", "--preset", "paint/glossy_red"], env, cwd=str(ROOT))
        for arm, tree in trees.items():
            run_child([*SVGEN, "render", str(w), str(work / f"w_{arm}.zarr"), "--views", str(a.views), "--res",
                       str(a.res), "--workers", str(a.workers)],
                      {**env, "PYTHONPATH": str(tree)}, cwd=str(tree))
        rounds = {k: [] for k in trees}
        for r in range(a.rounds):
            for arm in ("before", "after") if r % 2 == 0 else ("after", "before"):
                out = work / f"r_{arm}_{r}.zarr"
                env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": str(trees[arm])}
                m = run_child([*SVGEN, "render", str(v), str(out), "--views", str(a.views), "--res", str(a.res),
                               "--workers", str(a.workers)], env, cwd=str(trees[arm]), peak_rss=True)
                rounds[arm].append({"wall_s": round(m["wall_s"], 3), "cpu_s": round(m["cpu_s"], 3),
                                    "peak_rss_bytes": m["peak_rss_bytes"]})
                print(arm, r, rounds[arm][-1], flush=True)
        x, y = zarr.open_group(work / "r_before_0.zarr", mode="r"), zarr.open_group(work / "r_after_0.zarr", mode="r")
        same = sorted(x.array_keys()) == sorted(y.array_keys()) and all(
            np.array_equal(x[k][:], y[k][:]) for k in x.array_keys())
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(old)], capture_output=True)
        shutil.rmtree(work, ignore_errors=True)
    med = {k: {f: statistics.median(r[f] for r in v) for f in ("wall_s", "cpu_s")} for k, v in rounds.items()}
    views = n * a.views
    res = {"experiment": "packed_texels.ab_render", "before": a.before, "after": head, "svbrdfs": n, "views": views,
           "res": a.res, "size": a.size, "workers": a.workers, "rounds": rounds, "median": med,
           "same_arrays": bool(same),
           "cpu_ms_per_view": {k: round(1000 * m["cpu_s"] / views, 2) for k, m in med.items()},
           "after_over_before_cpu": round(med["after"]["cpu_s"] / med["before"]["cpu_s"], 4),
           "after_over_before_wall": round(med["after"]["wall_s"] / med["before"]["wall_s"], 4),
           "note": a.note,
           "command": "python3 experiments/packed_texels/ab_render.py " + " ".join(argv or sys.argv[1:])}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps({k: res[k] for k in ("cpu_ms_per_view", "after_over_before_cpu", "after_over_before_wall",
                                          "same_arrays")}))
    return res


if __name__ == "__main__":
    main()
