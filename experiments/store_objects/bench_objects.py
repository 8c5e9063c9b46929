"""Objects per 10,000 views of a real renders store at the default configuration (issue #12's aim: <= 200).

Renders the default pipeline's variants store (params.yaml: ``sample.per_preset`` 3 of the 51 presets, 153
SVBRDFs of 256^2, written here with the default ``SampleConfig`` otherwise) with the default ``RenderConfig`` (10
views of 256^2, 64 SVBRDFs per task: one shard per array per task; 3 tasks, the last one of 25) on 2 local dask
workers, then counts the finished store's chunk objects (every file under an array's ``c/`` folder: what an object
store or ``dvc push`` pays per object), all its files, and its bytes per view; the same for the variants store.

    python3 experiments/store_objects/bench_objects.py [--per-preset 3] --note "..."   # -> results/objects.json
"""
from __future__ import annotations

import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

from materials import registry
from pipeline.config import RenderConfig, SampleConfig
from pipeline.render.stage import run_render
from pipeline.sample import run_sample
from svcore.config import build

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

#: this experiment's frozen results (experiments/store_objects/results/)
RESULTS = Path(__file__).resolve().parent / "results"


def count(store: Path) -> dict:
    """Chunk objects per array (files under ``<array>/c/``), all files, bytes."""
    files = [f for f in store.rglob("*") if f.is_file()]
    per_array = {}
    for a in sorted(p.name for p in store.iterdir() if (p / "zarr.json").exists()):
        per_array[a] = sum(1 for f in (store / a / "c").rglob("*") if f.is_file()) if (store / a / "c").exists() else 0
    return {"chunk_objects": sum(per_array.values()), "chunk_objects_by_array": per_array, "files": len(files),
            "bytes": sum(f.stat().st_size for f in files)}


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--per-preset", type=int, default=3)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(RESULTS / "objects.json"))
    args = ap.parse_args()
    cfg = build(RenderConfig, "default")
    tmp = Path(tempfile.mkdtemp(prefix="svgen-bench-objects-"))
    try:
        variants = tmp / "variants.zarr"
        run_sample(variants, build(SampleConfig, "default", per_preset=args.per_preset), workers=args.workers)
        n_in = len(registry.presets()) * args.per_preset
        out = tmp / "renders.zarr"
        t = time.perf_counter()
        run_render(variants, out, cfg, workers=args.workers)
        wall = time.perf_counter() - t
        from storage.renders_store import RendersReader

        views = len(RendersReader(out))
        c, cv = count(out), count(variants)
        result = {
            "benchmark": "objects",
            "config": {"render": cfg.model_dump(), "sample_chunk": SampleConfig().chunk},
            "svbrdfs": views // cfg.views, "views": views, "tasks": -(-(views // cfg.views) // cfg.chunk),
            **c,
            "chunk_objects_per_10k_views": c["chunk_objects"] / views * 10_000,
            "files_per_10k_views": c["files"] / views * 10_000,
            "bytes_per_view": c["bytes"] / views,
            "aim_chunk_objects_per_10k_views": 200,
            "variants_store": {"variants": n_in, **cv, "chunk_objects_per_10k_variants": cv["chunk_objects"] / n_in
                               * 10_000},
            "render_wall_s": wall,
        }
        write_results(args.out, result, args.note)
        print(json.dumps({k: v for k, v in result.items() if k != "config"}, indent=1))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
