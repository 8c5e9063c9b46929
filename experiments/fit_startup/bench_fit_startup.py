"""What the start of `svtrain fit` costs before its first step: opening the store, the held-out split, the loader's
memory budget, and the first batch out of the loader's worker processes.

A renders store is made first (``svgen sample`` + ``svgen render`` in-process, the tiny configs: 64^2, 2 views per
SVBRDF), so the figures are the per-view costs that grow with a store (the split reads every view's presets) plus
the fixed ones (worker start, imports). Each phase is timed as `train.fit.fit` runs it, on the same functions.

    python3 experiments/fit_startup/bench_fit_startup.py [--per-preset 8] [--workers 2]
    # -> experiments/fit_startup/results/fit_startup.json
"""
from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, timed, write_results  # noqa: E402

#: this experiment's frozen results (experiments/fit_startup/results/)
RESULTS = Path(__file__).resolve().parent / "results"


def build_store(root: Path, per_preset: int) -> Path:
    from materials import presets
    from pipeline.config import RenderConfig, SampleConfig
    from pipeline.render.stage import run_render
    from pipeline.sample import run_sample
    from svcore.config import build

    names = tuple(sorted(p.name for p in presets()))
    run_sample(root / "v.zarr", build(SampleConfig, "tiny", presets=names, per_preset=per_preset), workers=0)
    run_render(root / "v.zarr", root / "r.zarr", build(RenderConfig, "tiny", chunk=1), workers=0)
    return root / "r.zarr"


def startup(store: Path, workers: int) -> dict:
    """Seconds (wall) of each phase of a fit's start, in fit's order."""
    from train import loader_memory
    from train.config import resolve
    from train.data import PairDataset, make_loader, open_source, split_for

    cfg = resolve("compact", None, {"data.store": str(store), "data.crop": 64, "model.levels": 6,
                                    "data.workers": workers})
    t = {}
    src = timed(lambda: open_source(cfg.data))
    t["open_store_s"] = src.wall_s
    split = timed(lambda: split_for(src.result, cfg.data))
    t["split_s"] = split.wall_s
    share = timed(lambda: loader_memory.share(src.result, loader_memory.per_process(cfg.data, src.result)))
    t["memory_budget_s"] = share.wall_s
    train_idx = split.result[0]

    def first_batch():
        ds = PairDataset(src.result, train_idx, cfg.data.crop, cfg.optim.seed)
        it = iter(make_loader(ds, cfg.optim.batch_size, 0, 4, workers))
        out = next(it)
        del it  # stops the workers
        return out

    t["first_batch_s"] = timed(first_batch).wall_s
    t["total_s"] = sum(t.values())
    return {"views": len(src.result), "train_views": int(len(train_idx)), "workers": workers, **t}


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--per-preset", type=int, default=8, help="variants per preset of the store (sample tiny)")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        store = build_store(Path(d), args.per_preset)
        built = time.perf_counter() - t0
        res = {"store": {"per_preset": args.per_preset, "res": 64, "build_s": built}, **startup(store, args.workers)}
    write_results(RESULTS / "fit_startup.json", res, note=args.note)
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
