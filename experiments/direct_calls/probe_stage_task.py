"""The render stage's own task, per commit: CPU per view of ``_chunk_task`` (read and decode the maps, draw the views,
render, encode, compress, write the shard), without the command's start, the cluster or the store's finish (#42).

Each round starts one child process per arm (a git worktree of each commit in ``--arms``), in alternating order.
The child opens a renders writer on the given variants store (the default render config: 10 views at 256^2, tasks
of 64 SVBRDFs, one drjit thread), runs the store's last task once to warm up, then times its first ``--tasks``
tasks (process CPU). It returns the CPU per view and a digest of the images it wrote. The arms must give the same
images.

    PYTHONPATH=. python3 experiments/direct_calls/probe_stage_task.py --variants V.zarr --arms 9d52ebf HEAD
"""
from __future__ import annotations

import hashlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from harness import parser, write_results  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"


def child(variants: str, tasks: int) -> None:
    """Run in a child process whose PYTHONPATH is the arm's tree: time the tasks, print JSON."""
    import time

    import numpy as np
    import zarr

    from pipeline.config import RenderConfig
    from pipeline.render.stage import chunk_task, render_writer

    cfg = RenderConfig()
    out = Path(tempfile.mkdtemp(prefix="probe_stage_task_")) / "r.zarr"
    w, n = render_writer((variants,), out, cfg)
    last = -(-n // cfg.chunk) - 1
    if tasks > last:
        raise SystemExit(f"the store has {last + 1} tasks: time at most {last} after the warm-up")
    with w:
        task = chunk_task(w, (variants,), cfg, n)
        task(last, 1)  # warm-up: the scene, its kernels (from drjit's cache), the inputs opened
        cpu, views = [], 0
        for c in range(tasks):
            c0 = time.process_time()
            views += task(c, 1)
            cpu.append(time.process_time() - c0)
        images = zarr.open_group(str(w.partial), mode="r")["image"][: tasks * cfg.chunk]
    print(json.dumps({"cpu_ms_per_view": 1e3 * sum(cpu) / views, "views": views,
                      "digest": hashlib.sha256(np.ascontiguousarray(images).tobytes()).hexdigest()}))


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--variants", required=True, help="a variants store of at least 3 tasks (129+ SVBRDFs)")
    ap.add_argument("--arms", nargs="+", default=[])
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--tasks", type=int, default=2)
    ap.add_argument("--out", default=str(RESULTS / "probe_stage_task.json"))
    ap.add_argument("--child", action="store_true")
    a = ap.parse_args(argv)
    if a.child:
        return child(a.variants, a.tasks)
    if len(a.arms) < 2:
        ap.error("--arms needs at least two commits")
    variants = str(Path(a.variants).resolve())
    work = Path(tempfile.mkdtemp(prefix="probe_stage_task_"))
    trees = {}
    try:
        for c in a.arms:
            t = work / c
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(t), c], check=True,
                           capture_output=True)
            trees[c] = t
        rows = {c: [] for c in a.arms}
        digests = set()
        for r in range(a.rounds):
            for c in (a.arms if r % 2 == 0 else a.arms[::-1]):
                out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", "--variants", variants,
                                      "--tasks", str(a.tasks)],
                                     env={**os.environ, "PYTHONPATH": str(trees[c]), "SVGEN_NO_PROGRESS": "1"},
                                     capture_output=True, text=True, check=True, cwd=str(trees[c]))
                d = json.loads(out.stdout.strip().splitlines()[-1])
                rows[c].append(d["cpu_ms_per_view"])
                digests.add(d["digest"])
                print(r, c, round(d["cpu_ms_per_view"], 3), flush=True)
        first = a.arms[0]
        result = {"experiment": "direct_calls.probe_stage_task", "variants": variants, "rounds": a.rounds,
                  "tasks_per_child": a.tasks, "views_per_child": d["views"], "arms": a.arms,
                  "same_images": len(digests) == 1, "cpu_ms_per_view_rounds": rows,
                  "cpu_ms_per_view_median": {c: statistics.median(v) for c, v in rows.items()},
                  "lower_than_first_arm_in_rounds": {c: sum(x < y for x, y in zip(rows[c], rows[first]))
                                                     for c in a.arms[1:]}}
        write_results(a.out, result, a.note)
        print(json.dumps({k: v for k, v in result.items() if k != "cpu_ms_per_view_rounds"}, indent=1))
    finally:
        for t in trees.values():
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(t)], capture_output=True)


if __name__ == "__main__":
    main()
