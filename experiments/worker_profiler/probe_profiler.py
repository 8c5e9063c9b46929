"""What dask's worker profiler costs the render stage's tasks (#42): the same tasks on a local cluster with
``distributed.worker.profile.enabled`` on (dask's default: a stack sample of every worker thread each 10 ms, merged
each second) and off.

Per round and arm (alternating order): a fresh local cluster of 2 workers (svgen's ``dask_client``), every task of a
render of the given variants store (the default render config), the worker process's CPU around each task
(bench_render's measure), each worker's first task left out. Checks that both arms wrote the same images.

    PYTHONPATH=. python3 experiments/worker_profiler/probe_profiler.py --variants V.zarr   # 6+ tasks of 64
"""
from __future__ import annotations

import hashlib
import json
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_render import _timed  # noqa: E402
from harness import parser, write_results  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"


def run_arm(variants: str, profile: bool) -> tuple[float, str]:
    import dask
    import distributed  # noqa: F401  (its config defaults first: a dask.config.set before them hides them)
    import numpy as np
    import zarr

    from pipeline.config import RenderConfig
    from pipeline.exec.parallel import dask_client, threads_per_worker
    from pipeline.render.stage import chunk_task, render_writer

    cfg = RenderConfig()
    tmp = Path(tempfile.mkdtemp(prefix="probe_profiler_"))
    try:
        with dask.config.set({"distributed.worker.profile.enabled": profile}):
            writer, n = render_writer((variants,), tmp / "r.zarr", cfg)
            with writer as w, dask_client(2) as client:
                task = chunk_task(w, (variants,), cfg, n)
                threads = threads_per_worker(client)
                n_tasks = -(-n // cfg.chunk)
                stats = client.gather(client.map(_timed, [task] * n_tasks, list(range(n_tasks)), [threads] * n_tasks,
                                                 pure=False))
                images = zarr.open_group(str(w.partial), mode="r")["image"][:]
        by_pid: dict[int, list] = {}
        for st in sorted(stats, key=lambda x: x["t0"]):
            by_pid.setdefault(st["pid"], []).append(st)
        steady = [x for v in by_pid.values() for x in v[1:]]
        return (1e3 * sum(x["cpu"] for x in steady) / sum(x["views"] for x in steady),
                hashlib.sha256(np.ascontiguousarray(images).tobytes()).hexdigest())
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--variants", required=True)
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--out", default=str(RESULTS / "probe_profiler.json"))
    a = ap.parse_args(argv)
    variants = str(Path(a.variants).resolve())
    rows = {"profile_on": [], "profile_off": []}
    digests = set()
    for r in range(a.rounds):
        for arm in (("profile_on", "profile_off") if r % 2 == 0 else ("profile_off", "profile_on")):
            ms, d = run_arm(variants, arm == "profile_on")
            rows[arm].append(ms)
            digests.add(d)
            print(r, arm, round(ms, 3), flush=True)
    result = {"experiment": "worker_profiler.probe_profiler", "variants": variants, "rounds": a.rounds,
              "same_images": len(digests) == 1, "cpu_ms_per_view_rounds": rows,
              "cpu_ms_per_view_median": {k: statistics.median(v) for k, v in rows.items()},
              "off_lower_in_rounds": sum(x < y for x, y in zip(rows["profile_off"], rows["profile_on"]))}
    write_results(a.out, result, a.note)
    print(json.dumps({k: v for k, v in result.items() if k != "cpu_ms_per_view_rounds"}, indent=1))


if __name__ == "__main__":
    main()
