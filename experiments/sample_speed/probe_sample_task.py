"""CPU per variant of the sample stage's chunk task, two checkouts, rounds interleaved (#42).

The stage's wall time on this VM swings by 20 % between runs minutes apart (``stage_ab.py``), more than the
changes measured here. This probe times the part that scales with the variants: in a fresh process per arm and
round (its working directory and ``PYTHONPATH`` the arm's checkout, so each imports its own code), the paper
preset's plan is built, a store writer opened in a temporary folder, one chunk task run as a warm-up (imports,
caches), and then ``--chunks`` chunk tasks spread over the plan are timed with ``time.process_time`` (user + system
CPU of the process: the generator, the relief, validation, encoding, zstd and the write).

The process gets the malloc environment a local dask worker of that checkout gets
(``pipeline.exec.parallel.worker_malloc_env``, when the checkout has it; none otherwise, as dask's nanny leaves it
with svgen's override), so the arm measures what its workers run. The malloc arm this served was reverted: no
checkout after it has ``worker_malloc_env``, and both arms then run with none.

    python3 experiments/sample_speed/probe_sample_task.py --against /work/wt_s0 --rounds 6
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from harness import machine_info  # noqa: E402

CHILD = r"""
import json, os, resource, sys, tempfile, time
from svcore.config import build
from pipeline.config import SampleConfig
from pipeline.sample import sample_stage
chunks = json.loads(sys.argv[1])
cfg = build(SampleConfig, "paper")
stage = sample_stage(cfg)
with tempfile.TemporaryDirectory() as d:
    with stage.writer(os.path.join(d, "v.zarr")) as w:
        task = stage.task_for(w)
        task(chunks[0], 1)  # warm-up: imports, caches, the first chunk's buffers
        r0 = resource.getrusage(resource.RUSAGE_SELF)
        t0 = time.process_time()
        n = sum(task(c, 1) for c in chunks[1:])
        cpu = time.process_time() - t0
        r1 = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"variants": n, "cpu_s": cpu, "user_s": r1.ru_utime - r0.ru_utime, "sys_s": r1.ru_stime - r0.ru_stime,
                  "minflt": r1.ru_minflt - r0.ru_minflt, "malloc_env": {k: v for k, v in os.environ.items()
                                                                       if k.startswith("MALLOC_")}}))
"""

MALLOC_OF = r"""
import json
try:
    from pipeline.exec.parallel import worker_malloc_env
    print(json.dumps({k: v for k, v in worker_malloc_env().items() if v is not None}))
except ImportError:
    print("{}")
"""


def arm_env(code: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    env.update({"PYTHONPATH": str(code), "SVGEN_NO_PROGRESS": "1", "OMP_NUM_THREADS": "1"})
    got = subprocess.run([sys.executable, "-c", MALLOC_OF], env=env, cwd=str(code), capture_output=True, text=True,
                         check=True).stdout
    env.update(json.loads(got))
    return env


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--this", default=str(ROOT))
    ap.add_argument("--against", required=True)
    ap.add_argument("--chunks", type=int, nargs="+", default=[0, 3, 8, 13, 18, 23, 27],
                    help="chunk ids of the paper plan (64 variants each): the first is the warm-up")
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=str(HERE / "results" / "sample_task.json"))
    a = ap.parse_args(argv)
    codes = {"this": Path(a.this).resolve(), "against": Path(a.against).resolve()}
    envs = {t: arm_env(c) for t, c in codes.items()}
    rows = []
    for r in range(a.rounds):
        order = list(codes) if r % 2 == 0 else list(codes)[::-1]
        row = {}
        for tag in order:
            out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(a.chunks)], env=envs[tag],
                                 cwd=str(codes[tag]), capture_output=True, text=True)
            if out.returncode:
                raise SystemExit(f"{tag}: {out.stderr[-2000:]}")
            row[tag] = json.loads(out.stdout.strip().splitlines()[-1])
            row[tag]["cpu_ms_per_variant"] = round(1000 * row[tag]["cpu_s"] / row[tag]["variants"], 3)
            print(f"round {r} {tag}: {row[tag]['cpu_ms_per_variant']:.2f} CPU ms/variant "
                  f"(sys {row[tag]['sys_s']:.2f} s, {row[tag]['minflt']} faults)", flush=True)
        rows.append(row)
    per = {t: [r[t]["cpu_ms_per_variant"] for r in rows] for t in codes}
    diffs = [r["this"]["cpu_ms_per_variant"] - r["against"]["cpu_ms_per_variant"] for r in rows]
    result = {"experiment": "sample_speed/probe_sample_task", "chunks": a.chunks, "rounds": rows,
              "median_cpu_ms_per_variant": {t: statistics.median(v) for t, v in per.items()},
              "paired_diff_ms": diffs, "median_paired_diff_ms": statistics.median(diffs),
              "pairs_faster": sum(d < 0 for d in diffs), "codes": {k: str(v) for k, v in codes.items()},
              "command": "python3 " + " ".join([str(Path(sys.argv[0]))] + sys.argv[1:]), "note": a.note,
              "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "machine": machine_info()}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps({k: result[k] for k in ("median_cpu_ms_per_variant", "median_paired_diff_ms", "pairs_faster")}))
    return result


if __name__ == "__main__":
    main()
