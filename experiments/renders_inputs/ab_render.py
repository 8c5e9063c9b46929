"""What a renders store without maps (format 6, ``render.maps: inputs``) saves and costs against one with them
(``render.maps: stored``, format 4), on the same inputs, with the same code (#42).

1. **The render stage.** The given variants and blends stores rendered ``--rounds`` times each way (``svgen render V
   B OUT``, 10 views at 288², 2 workers, each run its own process as a user runs it: wall and CPU of the process tree,
   benchmarks/harness.run_child), the two arms alternating which goes first. Records each store's bytes on disk.
2. **The same data.** The two stores hold the same images, views and indices, byte for byte, and the reader of the
   store without maps gives every SVBRDF's base-map codes equal to the other's copy.
3. **A training read.** What :meth:`storage.renders_store.RendersReader.crop` costs per view (a 256² crop of a
   random view, the paper's training read), from each store, in one process, blocks of ``--block`` reads
   alternating: CPU and wall ms per read, with the budget of one loader worker (``--cache-mib``).

    python3 experiments/renders_inputs/ab_render.py --variants ../ps2/variants.zarr --blends ../ps2/blends.zarr
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from harness import SVGEN, run_child  # noqa: E402


def du(path: Path) -> int:
    return sum(f.stat().st_size for f in Path(path).rglob("*") if f.is_file())


def render_rounds(a, work: Path, env: dict) -> tuple[dict, dict]:
    """The render stage, each arm ``a.rounds`` times, alternating; returns (rounds, the first store of each arm)."""
    rounds, first = {"stored": [], "inputs": []}, {}
    base = ["--config-preset", "paper", "--views", str(a.views), "--res", str(a.res), "--workers", str(a.workers)]
    w = work / "warm.zarr"  # an untimed warm-up: drjit compiles its kernels into its cache once
    run_child([*SVGEN, "render", str(a.variants), str(w), *base, "--set", "maps=stored"], env, cwd=str(ROOT))
    shutil.rmtree(w)
    for r in range(a.rounds):
        for arm in ("stored", "inputs") if r % 2 == 0 else ("inputs", "stored"):
            out = work / f"r_{arm}_{r}.zarr"  # beside the inputs' copies: a store without maps records them
            m = run_child([*SVGEN, "render", str(work / Path(a.variants).name), str(work / Path(a.blends).name),
                           str(out), *base, "--set",
                           f"maps={arm}"], env, cwd=str(ROOT), peak_rss=True)
            rounds[arm].append({"wall_s": round(m["wall_s"], 3), "cpu_s": round(m["cpu_s"], 3),
                                "peak_rss_bytes": m["peak_rss_bytes"], "disk_bytes": du(out)})
            print(arm, r, rounds[arm][-1], flush=True)
            if r == 0:
                first[arm] = out
            else:
                shutil.rmtree(out)
    return rounds, first


def same_data(stored: Path, inputs: Path) -> dict:
    """Arrays both stores hold, byte for byte; every SVBRDF's codes from the inputs equal to the stored copy."""
    import zarr

    from materials.maps import MAP_NAMES
    from storage.renders_store import RendersReader

    x, y = zarr.open_group(stored, mode="r"), zarr.open_group(inputs, mode="r")
    common = sorted(set(x.array_keys()) & set(y.array_keys()))
    arrays = all(np.array_equal(x[k][:], y[k][:]) for k in common)
    a, b = RendersReader(stored), RendersReader(inputs)
    codes = all(np.array_equal(a.base_codes(s)[k], b.base_codes(s)[k]) for s in range(a.n_svbrdf) for k in MAP_NAMES)
    return {"arrays_compared": common, "arrays_equal": bool(arrays), "svbrdfs": a.n_svbrdf,
            "maps_equal_every_svbrdf": bool(codes), "only_in_stored": sorted(set(x.array_keys()) - set(common))}


def read_cost(stores: dict, a) -> dict:
    """CPU and wall ms per 256² crop of a random view, blocks alternating between the stores."""
    from storage.renders_store import RendersReader

    readers = {k: RendersReader(p) for k, p in stores.items()}
    for r in readers.values():
        r.set_cache_bytes(a.cache_mib << 20)
    n = len(next(iter(readers.values())))
    rng = np.random.default_rng(0)
    views = rng.integers(0, n, a.reads)
    off = readers["stored"].res - a.crop
    corner = rng.integers(0, off + 1, (a.reads, 2))
    per = {k: {"cpu_s": 0.0, "wall_s": 0.0, "reads": 0} for k in readers}
    for b0 in range(0, a.reads, a.block):
        order = list(readers) if (b0 // a.block) % 2 == 0 else list(readers)[::-1]
        for k in order:  # the same views from each store, in the same order
            t, c = time.perf_counter(), time.process_time()
            for j in range(b0, min(a.reads, b0 + a.block)):
                readers[k].crop(int(views[j]), int(corner[j, 0]), int(corner[j, 1]), a.crop)
            per[k]["cpu_s"] += time.process_time() - c
            per[k]["wall_s"] += time.perf_counter() - t
            per[k]["reads"] += min(a.reads, b0 + a.block) - b0
    return {k: {"cpu_ms_per_read": round(1000 * v["cpu_s"] / v["reads"], 2),
                "wall_ms_per_read": round(1000 * v["wall_s"] / v["reads"], 2), "reads": v["reads"]}
            for k, v in per.items()}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variants", required=True)
    ap.add_argument("--blends", required=True, help="a recipe blends store of --variants")
    ap.add_argument("--views", type=int, default=10)
    ap.add_argument("--res", type=int, default=288)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--reads", type=int, default=600)
    ap.add_argument("--block", type=int, default=50)
    ap.add_argument("--crop", type=int, default=256)
    ap.add_argument("--cache-mib", type=int, default=512, help="one loader worker's cache budget")
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "ab_render.json"))
    a = ap.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="ab_inputs_"))
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": str(ROOT)}
    try:
        # copies side by side under their own names: the blends store records its variants store relative to it
        shutil.copytree(a.variants, work / Path(a.variants).name)
        shutil.copytree(a.blends, work / Path(a.blends).name)
        rounds, first = render_rounds(a, work, env)
        same = same_data(first["stored"], first["inputs"])
        reads = read_cost(first, a)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    import zarr

    n_svbrdf = same["svbrdfs"]
    views = n_svbrdf * a.views
    med = {k: {f: statistics.median(r[f] for r in v) for f in ("wall_s", "cpu_s", "disk_bytes")}
           for k, v in rounds.items()}
    res = {"experiment": "renders_inputs.ab_render", "variants": str(a.variants), "blends": str(a.blends),
           "svbrdfs": n_svbrdf, "views": views, "res": a.res, "workers": a.workers, "rounds": rounds, "median": med,
           "cpu_ms_per_view": {k: round(1000 * m["cpu_s"] / views, 2) for k, m in med.items()},
           "bytes_per_view": {k: round(m["disk_bytes"] / views) for k, m in med.items()},
           "inputs_over_stored_cpu": round(med["inputs"]["cpu_s"] / med["stored"]["cpu_s"], 4),
           "inputs_over_stored_wall": round(med["inputs"]["wall_s"] / med["stored"]["wall_s"], 4),
           "inputs_over_stored_bytes": round(med["inputs"]["disk_bytes"] / med["stored"]["disk_bytes"], 4),
           "same": same, "read": reads, "read_crop": a.crop, "read_cache_mib": a.cache_mib,
           "zarr": zarr.__version__, "note": a.note,
           "command": "python3 experiments/renders_inputs/ab_render.py " + " ".join(argv or sys.argv[1:])}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps({k: res[k] for k in ("cpu_ms_per_view", "bytes_per_view", "inputs_over_stored_cpu",
                                          "inputs_over_stored_wall", "read")}))
    return res


if __name__ == "__main__":
    main()
