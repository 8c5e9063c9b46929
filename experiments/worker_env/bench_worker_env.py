"""The data stages on a local dask cluster with and without dask's MALLOC_TRIM_THRESHOLD_ in the workers (#24).

dask's nanny exports ``MALLOC_TRIM_THRESHOLD_=65536`` to every worker it spawns. Setting that variable at all
turns off glibc's dynamic mmap threshold, so every array above 128 KiB (a 256² map is 256-768 KiB) is a fresh
``mmap``, page-faulted in and unmapped when freed. svgen's local cluster now leaves it unset
(``pipeline/exec/parallel.py``); this script runs `svgen sample`, `svgen blend` and `svgen render` with 2 local
workers as they are now ("svgen") and with the variable exported as dask sets it ("dask_default": the workers
inherit it), and records wall, user and system CPU of each command (``RUSAGE_CHILDREN``).

Writes experiments/worker_env/results/worker_env.json. Usage:
    python3 experiments/worker_env/bench_worker_env.py [--per-preset 4] [--blends 2000] [--render-per-preset 1]
"""
from __future__ import annotations

import os
import shutil
import sys
import tempfile
from pathlib import Path

# harness.py stays in benchmarks/; this finished experiment imports it from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, run_child, write_results  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"

DASK_DEFAULT = "65536"  # distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_


def run(cmd: list[str], env: dict) -> dict:
    """Wall, user and system seconds of one command (its whole process tree: :func:`harness.run_child`)."""
    m = run_child(cmd, env)
    return {k: round(m[k], 2) for k in ("wall_s", "user_s", "sys_s")}


def stages(d: Path, env: dict, a) -> dict:
    """sample -> blend on the large inputs, sample -> blend -> render on the small ones; per-command timings."""
    w = ["--workers", "2"]
    out = {}
    out["sample"] = run(["svgen", "sample", str(d / "v.zarr"), "--per-preset", str(a.per_preset), *w], env)
    out["blend"] = run(["svgen", "blend", str(d / "v.zarr"), str(d / "b.zarr"), "--count", str(a.blends), *w], env)
    run(["svgen", "sample", str(d / "rv.zarr"), "--per-preset", str(a.render_per_preset), *w], env)
    run(["svgen", "blend", str(d / "rv.zarr"), str(d / "rb.zarr"), "--count", str(a.render_blends), *w], env)
    out["render"] = run(["svgen", "render", str(d / "rv.zarr"), str(d / "rb.zarr"), str(d / "r.zarr"), *w], env)
    return out


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--per-preset", type=int, default=4, help="variants per base material of the sample/blend run")
    ap.add_argument("--blends", type=int, default=2000)
    ap.add_argument("--render-per-preset", type=int, default=1, help="variants per base material rendered")
    ap.add_argument("--render-blends", type=int, default=100)
    ap.add_argument("--out", default=str(RESULTS / "worker_env.json"))
    a = ap.parse_args(argv)
    base = {k: v for k, v in os.environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}
    base["SVGEN_NO_PROGRESS"] = "1"
    arms = {"svgen": base, "dask_default": {**base, "MALLOC_TRIM_THRESHOLD_": DASK_DEFAULT}}
    res: dict = {"workers": 2, "per_preset": a.per_preset, "blends": a.blends,
                 "render_per_preset": a.render_per_preset, "render_blends": a.render_blends, "arms": {}}
    for name, env in arms.items():
        d = Path(tempfile.mkdtemp(prefix=f"worker_env_{name}_"))
        try:
            res["arms"][name] = stages(d, env, a)
        finally:
            shutil.rmtree(d, ignore_errors=True)
        print(name, res["arms"][name], flush=True)
    res["speedup_wall"] = {s: round(res["arms"]["dask_default"][s]["wall_s"] / res["arms"]["svgen"][s]["wall_s"], 2)
                           for s in res["arms"]["svgen"]}
    write_results(a.out, res, a.note, code=("pipeline", "storage", "materials", "svcore"))
    print("wall speed-up by stage:", res["speedup_wall"])
    return res


if __name__ == "__main__":
    main()
