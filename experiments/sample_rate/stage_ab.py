"""Sample and blend stage rates of two checkouts, rounds interleaved, as a user runs the stages (#42).

Each round runs, for each code (``--this``, ``--against``: their ``PYTHONPATH``), in its own process
(:func:`run_stage`, in the code's own folder: wall, CPU of the process tree, peak RSS):

* ``svgen sample V --config-preset paper --workers W --per-preset P`` (paper_scale.json's sample stage at
  ``--per-preset 2``: 364 variants at 288²), and
* ``svgen blend V B --config-preset paper --workers W --count N`` over that code's own variants store.

It then compares the two codes' stores chunk file by chunk file (their ``svgen_manifest.json``: size and SHA-256 of
every chunk file), so a speed change that moved a byte shows here. Results: ``results/stage_ab.json``.

    python3 experiments/sample_rate/stage_ab.py --against /work/wt42_base --note "loaded machine: ..."
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
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(1, str(ROOT))  # this checkout's materials registry counts the variants (the arms run in subprocesses)

from harness import SVGEN, machine_info, run_child  # noqa: E402


def run_stage(args: list[str], env: dict, code: Path) -> dict:
    """One ``svgen`` command in ``code``'s folder (``python -c`` puts the working directory ahead of PYTHONPATH:
    from another folder both arms would run that folder's code): wall, CPU of the process tree, peak RSS."""
    m = run_child([*SVGEN, *args], env, cwd=str(code), peak_rss=True)
    return {"wall_s": round(m["wall_s"], 3), "cpu_s": round(m["cpu_s"], 3), "user_s": round(m["user_s"], 3),
            "sys_s": round(m["sys_s"], 3), "peak_rss_bytes": m["peak_rss_bytes"]}


def manifest(path: Path) -> dict:
    return json.loads((path / "svgen_manifest.json").read_text())["arrays"]


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--this", default=str(ROOT), help="checkout measured as 'this' (default: this one)")
    ap.add_argument("--against", required=True, help="checkout measured as 'against' (e.g. a worktree of the code before)")
    ap.add_argument("--per-preset", type=int, default=2)
    ap.add_argument("--count", type=int, default=2000, help="blends per blend run (0: the sample stage only)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=str(HERE / "results" / "stage_ab.json"))
    a = ap.parse_args(argv)
    codes = {"this": Path(a.this).resolve(), "against": Path(a.against).resolve()}
    work = Path(tempfile.mkdtemp(prefix="stage_ab_"))
    rounds: list[dict] = []
    same = {}
    try:
        for r in range(a.rounds):
            row = {}
            order = list(codes) if r % 2 == 0 else list(codes)[::-1]  # alternate who goes first
            for tag in order:
                env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": str(codes[tag])}
                if r == 0:  # each arm imports its own code (run_stage's working directory)
                    got = subprocess.run([sys.executable, "-c", "import pipeline; print(pipeline.__file__)"], env=env,
                                         cwd=str(codes[tag]), capture_output=True, text=True, check=True).stdout
                    assert Path(got.strip()).resolve().is_relative_to(codes[tag]), (tag, got)
                v, b = work / f"{tag}_v.zarr", work / f"{tag}_b.zarr"
                for p in (v, b):
                    shutil.rmtree(p, ignore_errors=True)
                common = ["--config-preset", "paper", "--workers", str(a.workers)]
                load = os.getloadavg()[0]
                s = run_stage(["sample", str(v), *common, "--per-preset", str(a.per_preset)], env, codes[tag])
                bl = run_stage(["blend", str(v), str(b), *common, "--count", str(a.count)], env, codes[tag]) \
                    if a.count else {"wall_s": 0.0, "cpu_s": 0.0}
                row[tag] = {"sample": s, "blend": bl, "loadavg_1min_before": round(load, 2)}
                print(f"round {r} {tag}: sample {s['wall_s']:.1f} s wall {s['cpu_s']:.1f} CPU-s; "
                      f"blend {bl['wall_s']:.1f} s wall {bl['cpu_s']:.1f} CPU-s (load {load:.1f})", flush=True)
            if r == 0:  # the stores of both codes, chunk file by chunk file
                for kind in ("v", "b") if a.count else ("v",):
                    m_this, m_against = (manifest(work / f"{t}_{kind}.zarr") for t in ("this", "against"))
                    same[{"v": "variants", "b": "blends"}[kind]] = m_this == m_against
            rounds.append(row)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    from materials.registry import presets  # the variants count: presets x per_preset

    n_variants = len(list(presets())) * a.per_preset

    def summary(tag: str) -> dict:
        out = {}
        for stage, n in (("sample", n_variants), ("blend", a.count))[:2 if a.count else 1]:
            wall = statistics.median(r[tag][stage]["wall_s"] for r in rounds)
            cpu = statistics.median(r[tag][stage]["cpu_s"] for r in rounds)
            out[stage] = {"n": n, "median_wall_s": wall, "median_cpu_s": cpu,
                          "per_s": round(n / wall, 2), "cpu_ms_per_item": round(1000 * cpu / n, 2)}
        return out

    result = {"experiment": "sample_rate/stage_ab", "per_preset": a.per_preset, "variants": n_variants,
              "count": a.count, "workers": a.workers, "rounds": rounds,
              "this": summary("this"), "against": summary("against"),
              "same_chunk_files": same, "codes": {k: str(v) for k, v in codes.items()},
              "command": "python3 " + " ".join([str(Path(sys.argv[0]))] + sys.argv[1:]),
              "note": a.note, "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "machine": machine_info()}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps({k: result[k] for k in ("this", "against", "same_chunk_files")}, indent=1))
    return result


if __name__ == "__main__":
    main()
