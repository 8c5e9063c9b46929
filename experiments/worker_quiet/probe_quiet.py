"""What distributed's periodic machinery costs svgen's local cluster (#42): dask's defaults against svgen's
``pipeline.exec.parallel.QUIET_LOCAL_CLUSTER`` (profiler off, the tick, system and memory monitors less often).

Per round and arm (alternating order), a fresh local cluster of 2 workers (svgen's ``dask_client``; the dask-default
arm empties ``QUIET_LOCAL_CLUSTER`` first), then:

1. **idle**: ``--idle`` seconds with no task; the CPU each worker process and the parent (scheduler, nannies,
   client: this process) used, as a share of one core;
2. **busy**: ``--tasks`` chunk tasks of the paper preset's sample stage (64 variants at 288² each), each wrapped to
   read its worker's process CPU and the task thread's own CPU (``time.thread_time``) around it. The difference is
   what the worker's other threads (event loop, profiler, monitors) used while the task ran. Each worker's first task
   (imports, caches) is left out.

Checks that both arms wrote the same store (a digest over every file of the partial store).

    PYTHONPATH=. python3 experiments/worker_quiet/probe_quiet.py --rounds 4   # -> results/probe_quiet.json
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from harness import parser, write_results  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"


def _process_cpu() -> float:
    t = os.times()
    return t.user + t.system


def _measured(task, c: int, threads: int) -> dict:
    """One chunk task in a worker: its process's CPU, its own thread's CPU and wall time around it."""
    p0, t0, w0 = _process_cpu(), time.thread_time(), time.perf_counter()
    n = task(c, threads)
    return {"pid": os.getpid(), "start": w0, "n": n, "process_cpu": _process_cpu() - p0,
            "thread_cpu": time.thread_time() - t0, "wall": time.perf_counter() - w0}


def run_arm(quiet: bool, tasks: int, idle_s: float) -> dict:
    import distributed  # noqa: F401  (its config defaults first: a dask.config.set before them hides them)

    from pipeline.config import SampleConfig
    from pipeline.exec import parallel
    from pipeline.sample import sample_stage
    from svcore.config import build

    saved = dict(parallel.QUIET_LOCAL_CLUSTER)
    if not quiet:
        parallel.QUIET_LOCAL_CLUSTER.clear()
    tmp = Path(tempfile.mkdtemp(prefix="probe_quiet_"))
    try:
        stage = sample_stage(build(SampleConfig, "paper"))
        with stage.writer(tmp / "v.zarr") as w, parallel.dask_client(2) as client:
            # idle: every worker's and this process's CPU over idle_s seconds with nothing to do
            time.sleep(1.0)
            c0, m0 = client.run(_process_cpu), _process_cpu()
            time.sleep(idle_s)
            c1, m1 = client.run(_process_cpu), _process_cpu()
            idle_workers = [100 * (c1[k] - c0[k]) / idle_s for k in c0]
            idle_parent = 100 * (m1 - m0) / idle_s
            task = stage.task_for(w)
            stats = client.gather(client.map(_measured, [task] * tasks, list(range(tasks)), [1] * tasks, pure=False))
            h = hashlib.sha256()
            for f in sorted(p for p in Path(w.partial).rglob("*") if p.is_file()):
                h.update(str(f.relative_to(w.partial)).encode() + f.read_bytes())
        by_pid: dict[int, list] = {}
        for st in sorted(stats, key=lambda x: x["start"]):
            by_pid.setdefault(st["pid"], []).append(st)
        steady = [x for v in by_pid.values() for x in v[1:]]
        n = sum(x["n"] for x in steady)
        other = sum(x["process_cpu"] - x["thread_cpu"] for x in steady)
        return {"idle_worker_pct": idle_workers, "idle_parent_pct": idle_parent,
                "busy_other_threads_pct": 100 * other / sum(x["wall"] for x in steady),
                "busy_cpu_ms_per_variant": 1e3 * sum(x["process_cpu"] for x in steady) / n,
                "busy_other_threads_ms_per_variant": 1e3 * other / n, "steady_tasks": len(steady),
                "store_digest": h.hexdigest()}
    finally:
        parallel.QUIET_LOCAL_CLUSTER.clear()
        parallel.QUIET_LOCAL_CLUSTER.update(saved)
        shutil.rmtree(tmp, ignore_errors=True)


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--tasks", type=int, default=6, help="sample chunk tasks per arm and round (64 variants each)")
    ap.add_argument("--idle", type=float, default=10.0, help="seconds of the idle measurement")
    ap.add_argument("--out", default=str(RESULTS / "probe_quiet.json"))
    a = ap.parse_args(argv)
    rows: dict[str, list] = {"dask_default": [], "quiet": []}
    for r in range(a.rounds):
        for arm in (("dask_default", "quiet") if r % 2 == 0 else ("quiet", "dask_default")):
            row = run_arm(arm == "quiet", a.tasks, a.idle)
            rows[arm].append(row)
            print(r, arm, json.dumps({k: (round(v, 3) if isinstance(v, float) else v) for k, v in row.items()
                                      if k not in ("idle_worker_pct", "store_digest")}), flush=True)

    def med(arm: str, key: str) -> float:
        return statistics.median(x[key] if not isinstance(x[key], list) else statistics.mean(x[key])
                                 for x in rows[arm])

    keys = ("idle_worker_pct", "idle_parent_pct", "busy_other_threads_pct", "busy_other_threads_ms_per_variant",
            "busy_cpu_ms_per_variant")
    result = {"experiment": "worker_quiet.probe_quiet", "rounds": rows,
              "median": {arm: {k: round(med(arm, k), 3) for k in keys} for arm in rows},
              "busy_cpu_paired_diff_ms": [round(q["busy_cpu_ms_per_variant"] - d["busy_cpu_ms_per_variant"], 3)
                                          for q, d in zip(rows["quiet"], rows["dask_default"])],
              "same_store": len({x["store_digest"] for v in rows.values() for x in v}) == 1,
              "quiet_settings": __import__("pipeline.exec.parallel", fromlist=["x"]).QUIET_LOCAL_CLUSTER}
    write_results(a.out, result, a.note)
    print(json.dumps({k: result[k] for k in ("median", "busy_cpu_paired_diff_ms", "same_store")}, indent=1))


if __name__ == "__main__":
    main()
