"""Training throughput on CPU: it/s of the compact default (batch 8, 128² crops, rendering loss included),
loader samples/s (bar: >= 5x what training consumes), peak RSS.

    python3 benchmarks/bench_train.py            # -> benchmarks/results/train.json

The eval-after-budget table is measured by ``svtrain fit`` + ``svtrain eval`` on a real renders store.
"""
from __future__ import annotations

import json
import os
import resource
import time

import torch

from train.config import resolve
from train.data import PairDataset, make_loader, split_by_source
from train.fit import build, train_step
from train.loss import make_loss
from train.net import count_parameters
from train.synthetic import SyntheticSource

from harness import RESULTS, parser, write_results


def bench_steps(cfg, src, train_idx, steps: int, compile_loss: bool) -> dict:
    model, opt, gen = build(cfg)
    loss_fn = make_loss(compile_loss)
    ds = PairDataset(src, train_idx, cfg.data.crop, 0, train=True)
    b = cfg.optim.batch_size
    batches = []
    for t in range(4):
        items = [ds[t * b + k] for k in range(b)]
        batches.append((torch.stack([i[0] for i in items]), torch.stack([i[1] for i in items])))
    model.train()

    def step(t):
        img, maps = batches[t % len(batches)]
        return train_step(model, opt, loss_fn, img, maps, gen, cfg.optim, t)[0]

    t0 = time.perf_counter()
    step(0)  # warm-up (and the one-off compile)
    warm = time.perf_counter() - t0
    step(1)
    t0, c0 = time.perf_counter(), time.process_time()
    for t in range(steps):
        step(t)
    wall = time.perf_counter() - t0
    return {"it_per_s": steps / wall, "s_per_it": wall / steps, "cpu_s_per_it": (time.process_time() - c0) / steps,
            "warmup_s": round(warm, 1), "parameters": count_parameters(model)}


def bench_loader(cfg, src, train_idx, batches: int, workers: int) -> float:
    ds = PairDataset(src, train_idx, cfg.data.crop, 0, train=True)
    loader = make_loader(ds, cfg.optim.batch_size, 0, batches + 2, workers)
    it = iter(loader)
    next(it)
    next(it)  # workers started
    t0 = time.perf_counter()
    n = 0
    for img, _ in it:
        n += img.shape[0]
    return n / (time.perf_counter() - t0)


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--no-compile", action="store_true")
    ap.add_argument("--out", default=str(RESULTS / "train.json"))
    a = ap.parse_args(argv)
    torch.set_num_threads(a.threads)
    cfg = resolve("compact", None, {})
    src = SyntheticSource(64, cfg.data.synthetic_size, 8, seed=0)
    train_idx, _ = split_by_source(src, cfg.data.holdout, 0)
    load0 = os.getloadavg()[0]
    steps = bench_steps(cfg, src, train_idx, a.steps, not a.no_compile)
    loader = bench_loader(cfg, src, train_idx, 60, a.workers)
    consumption = steps["it_per_s"] * cfg.optim.batch_size
    out = {"benchmark": "bench_train", "preset": cfg.preset, "model": cfg.to_dict()["model"],
           "batch_size": cfg.optim.batch_size, "crop": cfg.data.crop, "threads": a.threads,
           "compile_loss": not a.no_compile, **{k: round(v, 3) if isinstance(v, float) else v for k, v in steps.items()},
           "loader_samples_per_s": round(loader, 1), "loader_workers": a.workers,
           "consumed_samples_per_s": round(consumption, 1), "loader_vs_consumption": round(loader / consumption, 2),
           "peak_rss_gb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6, 3),
           "load_average_before": round(load0, 2),
           "bars": {"it_per_s": 2.0, "loader_vs_consumption": 5.0}}
    write_results(a.out, out, a.note)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
