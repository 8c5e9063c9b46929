"""What the sample stage's start holds (#42): the command's imports, the local cluster, and each worker's first
calls of the presets.

Runs, each its own process as a user runs it (benchmarks/harness.run_child), ``--rounds`` times in turn:
``python3 -c "import pipeline.cli"`` (the imports), and `svgen sample --config-preset paper` of one variant of one
preset and of one variant of every preset, with ``--workers 0`` (in the command's process) and ``--workers 2`` (a
local dask cluster of 2 processes).

    python3 experiments/sample_full_count/probe_start.py   # -> results/start.json
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

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from harness import SVGEN, run_child  # noqa: E402


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "start.json"))
    a = ap.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="sample_start_"))
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": str(ROOT)}
    one = ["--preset", "paint/glossy_red"]
    cases = {"imports": None}
    for w in (0, 2):
        cases[f"1 preset, workers {w}"] = (one, w)
        cases[f"182 presets, workers {w}"] = ([], w)
    runs = {k: [] for k in cases}
    try:
        for r in range(a.rounds):
            for k, c in cases.items():
                if c is None:
                    argv_ = [sys.executable, "-c", "import pipeline.cli"]
                else:
                    out = work / f"v_{len(runs[k])}_{c[1]}_{len(c[0])}.zarr"
                    argv_ = [*SVGEN, "sample", str(out), "--config-preset", "paper", "--per-preset", "1",
                             "--workers", str(c[1]), *c[0]]
                m = run_child(argv_, env, cwd=str(ROOT))
                runs[k].append({"wall_s": round(m["wall_s"], 3), "cpu_s": round(m["cpu_s"], 3)})
                print(k, r, runs[k][-1], flush=True)
                if c is not None:
                    shutil.rmtree(out)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    med = {k: {f: round(statistics.median(x[f] for x in v), 3) for f in ("wall_s", "cpu_s")} for k, v in runs.items()}
    res = {"experiment": "sample_full_count.probe_start", "runs": runs, "median": med, "note": a.note,
           "command": "python3 experiments/sample_full_count/probe_start.py " + " ".join(argv or sys.argv[1:])}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps(med))
    return res


if __name__ == "__main__":
    main()
