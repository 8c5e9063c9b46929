"""Blend throughput at 256² on the local workers: ``svgen blend`` as a user runs it, startup separated from the work.

Makes one variants store with the default sample config (``--per-preset`` variants of every preset), then times
``svgen blend V B --count N --workers W`` and a small run of ``--small`` blends, each in its own process
(:func:`harness.run_child` in the code's own folder: wall, CPU of the process tree, peak RSS), ``--rounds`` times. The steady rate
is (N - small) / (wall_N - wall_small): the per-blend work without the start of the cluster and the store.
``--against DIR`` measures another checkout's code the same way in the same call (its ``PYTHONPATH``), rounds
interleaved, so that a speed change is compared on one machine in one state.

The stage's wall and CPU include the zstd write, dask and the store: on a 2-core VM they vary by about 10 % from
run to run, more than a change to the blend arithmetic moves them. ``compute`` therefore also times the blend
itself in one process per code (``--compute`` blends after a warm-up, CPU time, no write): draw, read and decode
both parents, blend, validate, encode.

Issue #24's aim: >= 200 blends/s on 2 cores; #42's: >= 150 as a stage. ``--maps`` is the store the stage writes:
``recipe`` (the default since #42: each blend's parents, weight and mask seeds, no maps; the mixing is then paid by
the render, which reads the maps, and ``compute`` is its cost there) or ``stored`` (the mixed maps, zstd-3).

    python3 benchmarks/bench_blend.py                          # -> benchmarks/results/blend.json
    python3 benchmarks/bench_blend.py --against ../old-checkout --note "quiet machine"
"""
from __future__ import annotations

import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_paper_scale import run_stage
from harness import RESULTS, ROOT, SVGEN, parser, run_child, write_results

AIM = 200.0

# one process per code (its PYTHONPATH): CPU ms per blend of draw + make_blend + validate + encode_maps, no write
COMPUTE = """
import sys, time
from pipeline.blend import draw, make_blend
from pipeline.config import BlendConfig
from storage.svbrdf_store import SVBRDFStore, encode_maps
src, n_warm, n = SVBRDFStore(sys.argv[1], "variants"), int(sys.argv[2]), int(sys.argv[3])
cfg = BlendConfig()
def work(r):
    for j in r:
        encode_maps(make_blend(src, draw(j, len(src), cfg), cfg).validate())
work(range(n_warm))
t = time.process_time()
work(range(n_warm, n_warm + n))
print(1000 * (time.process_time() - t) / n)
"""


def compute_ms(code: Path, v: Path, n: int) -> float:
    """CPU ms per blend of ``code``'s blend arithmetic (:data:`COMPUTE`), in its own process."""
    env = {**os.environ, "PYTHONPATH": str(code), "OMP_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, "-c", COMPUTE, str(v), str(n // 2), str(n)], env=env, capture_output=True,
                       text=True, check=True, cwd=str(code))  # (the code's folder: see measure)
    return round(float(r.stdout.strip().splitlines()[-1]), 3)


def measure(code: Path, v: Path, work: Path, count: int, small: int, workers: int, tag: str, maps: str) -> dict:
    """One round of one code: the full and the small blend run (their stores removed afterwards)."""
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": str(code)}
    out = {}
    for name, n in (("full", count), ("small", small)):
        b = work / f"{tag}_{name}.zarr"
        # in the code's own folder: ``python -c`` puts the working directory ahead of PYTHONPATH, so from another
        # checkout's root both arms ran that checkout's code (every --against figure before #42's fix)
        m = run_child([*SVGEN, "blend", str(v), str(b), "--count", str(n), "--workers", str(workers), "--maps", maps],
                      env, cwd=str(code), peak_rss=True)
        out[name] = {"wall_s": round(m["wall_s"], 3), "cpu_s": round(m["cpu_s"], 3), "peak_rss_bytes": m["peak_rss_bytes"]}
        shutil.rmtree(b, ignore_errors=True)
    return out


def summary(rounds: list[dict], count: int, small: int) -> dict:
    """Medians over rounds: wall and CPU of both runs, blends/s, steady blends/s and CPU ms per blend."""
    med = {f"{k}_{f}": statistics.median(r[k][f] for r in rounds) for k in ("full", "small") for f in ("wall_s", "cpu_s")}
    steady = (count - small) / max(med["full_wall_s"] - med["small_wall_s"], 1e-9)
    return {**{k: round(v, 3) for k, v in med.items()},
            "peak_rss_bytes": max(r["full"]["peak_rss_bytes"] for r in rounds),
            "blends_per_s": round(count / med["full_wall_s"], 2), "steady_blends_per_s": round(steady, 2),
            "cpu_ms_per_blend_steady": round(1000 * (med["full_cpu_s"] - med["small_cpu_s"]) / (count - small), 2),
            "rounds": rounds}


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--per-preset", type=int, default=2, help="variants per preset of the source store")
    ap.add_argument("--count", type=int, default=2000, help="blends of the timed run")
    ap.add_argument("--small", type=int, default=64, help="blends of the run that measures the startup")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--compute", type=int, default=500, help="blends timed in-process per round (no write)")
    ap.add_argument("--maps", choices=("recipe", "stored"), default="recipe",
                    help="what the stage stores (blend.maps); --against needs a checkout that has the option")
    ap.add_argument("--against", default=None, help="another checkout measured the same way (e.g. the code before)")
    ap.add_argument("--out", default=str(RESULTS / "blend.json"))
    a = ap.parse_args(argv)
    if not 0 < a.small < a.count:
        raise SystemExit(f"--small {a.small} must be in (0, --count {a.count})")
    work = Path(tempfile.mkdtemp(prefix="bench_blend_"))
    try:
        v = work / "variants.zarr"
        env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": str(ROOT)}
        source = run_stage(["sample", str(v), "--per-preset", str(a.per_preset), "--workers", str(a.workers)], env)
        codes = {"this": ROOT, **({"against": Path(a.against).resolve()} if a.against else {})}
        rounds = {k: [] for k in codes}
        compute = {k: [] for k in codes}
        for i in range(a.rounds):
            for k, code in codes.items():
                rounds[k].append(measure(code, v, work, a.count, a.small, a.workers, f"{k}{i}", a.maps))
            for k, code in codes.items():
                compute[k].append(compute_ms(code, v, a.compute))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    res = {"benchmark": "blend", "size": 256, "maps": a.maps, "workers": a.workers, "cpus": os.cpu_count(),
           "source": {"per_preset": a.per_preset, **source}, "count": a.count, "small": a.small, "aim_blends_per_s": AIM,
           **{k: summary(r, a.count, a.small) for k, r in rounds.items()},
           "compute": {"what": "CPU ms per blend in one process, no write (draw, read and decode, blend, validate, "
                               "encode); median of rounds", "blends": a.compute,
                       **{k: {"ms_per_blend": statistics.median(c), "rounds": c} for k, c in compute.items()}}}
    if a.against:
        res["against_path"] = Path(a.against).name
    for k in codes:
        s = res[k]
        print(f"{k}: {s['blends_per_s']} blends/s ({s['steady_blends_per_s']} steady), "
              f"{s['cpu_ms_per_blend_steady']} CPU ms per blend; compute only "
              f"{res['compute'][k]['ms_per_blend']} ms")
    write_results(a.out, res, a.note, code=("svcore", "materials", "storage", "pipeline"))
    return res


if __name__ == "__main__":
    main()
