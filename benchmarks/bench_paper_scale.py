"""Paper scale end to end: sample + blend + render with the paper presets at a fraction of the scale, projected.

Runs ``svgen sample|blend|render --config-preset paper`` (the presets' counts, read from pipeline/config.py at run
time: today 1,820 variants, 182 base materials x 10; 20,000 blends; 10 views of each at 288², about 218,000 views) with the counts multiplied by ``--scale`` (default 0.25; at least
one variant per base material and one blend), each stage as its own process, as a user runs them. Per stage it
records the wall time, the CPU seconds of the stage's process tree (its dask worker processes included: the
kernel counts every process the stage reaped), the peak resident memory of the whole process tree (sampled every
0.2 s), the store's bytes on disk and its objects (files). The full scale is projected linearly from the measured counts (every stage's work is per sample;
the one-time start of a stage's processes is counted in, so the projection errs on the high side).

Writes benchmarks/results/paper_scale.json. Usage:
    python3 benchmarks/bench_paper_scale.py [--scale 0.25] [--workers 2] [--workdir DIR] [--keep]
The stores are written under --workdir (default: a temporary folder, deleted afterwards unless --keep); at
--scale 0.25 they take about a quarter of the full scale's disk (see the projection of a smaller run first).
"""
from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

from harness import RESULTS, ROOT, SVGEN, parser, run_child, write_results



def paper_counts() -> tuple[int, int, int]:
    """The paper presets' (variants per base material, blends, views) from pipeline/config.py, so that the
    benchmark measures what `--config-preset paper` runs (the base materials are counted from the registry)."""
    from pipeline.config import BlendConfig, RenderConfig, SampleConfig

    return (SampleConfig.PRESETS["paper"]["per_preset"], BlendConfig.PRESETS["paper"]["count"],
            RenderConfig.PRESETS["paper"]["views"])

def run_stage(args: list[str], env: dict) -> dict:
    """Run one ``svgen`` command as its own process (:func:`harness.run_child`): wall_s, cpu_s (user + system of
    the process and of the processes it reaped: its dask workers) and peak_rss_bytes (of its process tree)."""
    m = run_child([*SVGEN, *args], env, peak_rss=True)
    return {"wall_s": round(m["wall_s"], 3), "cpu_s": round(m["cpu_s"], 3), "peak_rss_bytes": m["peak_rss_bytes"]}


def store_size(path: Path) -> tuple[int, int]:
    """(bytes, objects) of a store folder: the sum of its files' sizes and their count."""
    files = [f for f in path.rglob("*") if f.is_file()]
    return sum(f.stat().st_size for f in files), len(files)


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--scale", type=float, default=0.25, help="fraction of the paper's counts (default 0.25)")
    ap.add_argument("--workers", type=int, default=2, help="svgen --workers of every stage (default 2)")
    ap.add_argument("--workdir", default=None, help="where the stores are written (default: a temporary folder)")
    ap.add_argument("--keep", action="store_true", help="keep the stores")
    ap.add_argument("--out", default=str(RESULTS / "paper_scale.json"))
    a = ap.parse_args(argv)
    if not 0 < a.scale <= 1:
        raise SystemExit(f"--scale {a.scale}: a fraction in (0, 1]")
    from materials.registry import presets

    n_presets = len(list(presets()))
    PAPER_PER_PRESET, PAPER_BLENDS, PAPER_VIEWS = paper_counts()
    per_preset = max(1, round(PAPER_PER_PRESET * a.scale))
    blends = max(1, round(PAPER_BLENDS * a.scale))
    counts = {"sample": n_presets * per_preset, "blend": blends, "render": (n_presets * per_preset + blends) * PAPER_VIEWS}
    full = {"sample": n_presets * PAPER_PER_PRESET, "blend": PAPER_BLENDS,
            "render": (n_presets * PAPER_PER_PRESET + PAPER_BLENDS) * PAPER_VIEWS}
    units = {"sample": "variants", "blend": "blends", "render": "views"}
    work = Path(a.workdir) if a.workdir else Path(tempfile.mkdtemp(prefix="paper_scale_"))
    work.mkdir(parents=True, exist_ok=True)
    v, b, r = work / "variants.zarr", work / "blends.zarr", work / "renders.zarr"
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": os.environ.get("PYTHONPATH", str(ROOT))}
    common = ["--config-preset", "paper", "--workers", str(a.workers)]
    cmds = {"sample": ["sample", str(v), *common, "--per-preset", str(per_preset)],
            "blend": ["blend", str(v), str(b), *common, "--count", str(blends)],
            "render": ["render", str(v), str(b), str(r), *common]}
    stages = {}
    try:
        for name, args in cmds.items():
            m = run_stage(args, env)
            store = {"sample": v, "blend": b, "render": r}[name]
            m["disk_bytes"], m["objects"] = store_size(store)
            m[units[name]] = counts[name]
            m[f"{units[name]}_per_s"] = round(counts[name] / m["wall_s"], 2)
            m["command"] = "svgen " + " ".join(str(x) for x in args)
            stages[name] = m
            print(f"{name}: {json.dumps(m)}", file=sys.stderr)
    finally:
        if not a.keep and not a.workdir:
            shutil.rmtree(work, ignore_errors=True)
    views = counts["render"]
    wall = sum(s["wall_s"] for s in stages.values())
    cpu = sum(s["cpu_s"] for s in stages.values())
    disk = sum(s["disk_bytes"] for s in stages.values())
    proj = {name: {"count": full[name], "wall_s": round(stages[name]["wall_s"] * full[name] / counts[name], 1),
                   "cpu_s": round(stages[name]["cpu_s"] * full[name] / counts[name], 1),
                   "disk_bytes": int(stages[name]["disk_bytes"] * full[name] / counts[name]),
                   "objects": int(stages[name]["objects"] * full[name] / counts[name])} for name in stages}
    res = {
        "benchmark": "paper_scale",
        "scale": a.scale, "workers": a.workers, "cpus": os.cpu_count(), "base_materials": n_presets,
        "counts": counts, "stages": stages,
        "wall_s": round(wall, 2), "cpu_s": round(cpu, 2),
        "cpu_s_per_view": round(cpu / views, 5), "render_cpu_s_per_view": round(stages["render"]["cpu_s"] / views, 5),
        "bytes_per_view": round(stages["render"]["disk_bytes"] / views, 1),
        "disk_bytes": disk, "objects": sum(s["objects"] for s in stages.values()),
        "peak_rss_bytes": max(s["peak_rss_bytes"] for s in stages.values()),
        "projection": {"note": "linear in each stage's count from the measured run", "stages": proj,
                       "views": full["render"], "wall_s": round(sum(p["wall_s"] for p in proj.values()), 1),
                       "cpu_s": round(sum(p["cpu_s"] for p in proj.values()), 1),
                       "disk_bytes": sum(p["disk_bytes"] for p in proj.values())},
        "aim_wall_s": 1200,
    }
    write_results(a.out, res, a.note, code=("svcore", "materials", "storage", "pipeline"))
    print(json.dumps(res, indent=1))
    return res


if __name__ == "__main__":
    main()
