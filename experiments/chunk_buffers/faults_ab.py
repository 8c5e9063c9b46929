"""Page faults, user and system CPU of the render stage, the code before (``--before``, a git worktree) against
this checkout, in interleaved rounds (#42).

Each round runs ``svgen render VARIANTS BLENDS OUT --config-preset paper --workers 2`` with each code, as a user runs
it, and reads the process tree's rusage (``RUSAGE_CHILDREN``: minor page faults, user and system CPU). Writes
results/faults_ab.json. Inputs: paper-preset stores, e.g. those of experiments/store_levels' reproduce block.

    python3 experiments/chunk_buffers/faults_ab.py --before 5f5f7d9 --variants ../ps2/variants.zarr \\
        --blends ../ps2/blends.zarr
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SVGEN = [sys.executable, "-c", "import sys; from pipeline.cli import main; sys.argv[0] = 'svgen'; main()"]


def run(tree: Path, args: list[str]) -> dict:
    """One render by the code in ``tree``: wall, user, sys and minor faults of its process tree."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run([*SVGEN, *args], check=True, capture_output=True, cwd=str(tree),
                   env={**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": str(tree)})
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {"wall_s": round(wall, 2), "user_s": round(after.ru_utime - before.ru_utime, 2),
            "sys_s": round(after.ru_stime - before.ru_stime, 2), "minflt": after.ru_minflt - before.ru_minflt}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", required=True)
    ap.add_argument("--variants", required=True)
    ap.add_argument("--blends", required=True)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--note", default="")
    a = ap.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="faults_ab_"))
    old = work / "before"
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(old), a.before], check=True,
                   capture_output=True)
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    trees = {"before": old, "after": ROOT}
    ins = [str(Path(a.variants).resolve()), str(Path(a.blends).resolve())]
    rounds = {k: [] for k in trees}
    try:
        for r in range(a.rounds):
            for arm in ("before", "after") if r % 2 == 0 else ("after", "before"):
                out = work / f"{arm}.zarr"
                shutil.rmtree(out, ignore_errors=True)
                m = run(trees[arm], ["render", *ins, str(out), "--config-preset", "paper", "--workers", "2"])
                rounds[arm].append(m)
                print(arm, r, m, flush=True)
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(old)], capture_output=True)
        shutil.rmtree(work, ignore_errors=True)
    pairs = [{f: round(y[f] - x[f], 2) for f in ("wall_s", "user_s", "sys_s", "minflt")}
             for x, y in zip(rounds["before"], rounds["after"])]
    res = {"experiment": "chunk_buffers.faults_ab", "before": a.before, "after": head, "rounds": rounds,
           "after_minus_before": pairs,
           "median": {k: {f: statistics.median(m[f] for m in v) for f in ("wall_s", "user_s", "sys_s", "minflt")}
                      for k, v in rounds.items()},
           "note": a.note, "command": "python3 experiments/chunk_buffers/faults_ab.py " + " ".join(argv or sys.argv[1:])}
    out = Path(__file__).parent / "results" / "faults_ab.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps(res["median"]))
    return res


if __name__ == "__main__":
    main()
