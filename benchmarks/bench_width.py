"""Choose the compact network width by measurement (DESIGN.md: "model no more than the scene needs").

For each base width (max width = 8x base, 7 levels, 128² crops), train from the same seed for the
same CPU-time budget on the same synthetic data (materials presets rendered by the torch flash
renderer), then evaluate held-out RMSE (re-rendering and maps). The compact default is the smallest
width whose held-out error (mean of the columns) is within ``--tol`` (5 %) of the next larger width.

The lr is raised from the paper's 2e-5 (tuned for 400k steps) to 2e-4 so that a few-minute budget
moves the weights measurably; all widths share it.

    python3 benchmarks/bench_width.py --budget 240 --widths 8 16 32
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from train.config import resolve  # noqa: E402
from train.data import PairDataset, split_by_source  # noqa: E402
from train.evaluate import COLUMNS, evaluate, train_means  # noqa: E402
from train.fit import build  # noqa: E402
from train.loss import make_loss  # noqa: E402
from train.net import count_parameters  # noqa: E402
from train.synthetic import SyntheticSource  # noqa: E402


def run_width(base: int, src, train_idx, test_idx, means, budget: float, lr: float, seed: int) -> dict:
    cfg = resolve("compact", None, {"model.base_width": base, "model.max_width": 8 * base, "optim.lr": lr,
                                    "optim.seed": seed})
    model, opt, gen = build(cfg)
    loss_fn = make_loss(True)
    ds = PairDataset(src, train_idx, cfg.data.crop, seed, train=True)
    b = cfg.optim.batch_size
    # compile outside the budget (a one-off cost, cached on disk)
    warm = [ds[k] for k in range(b)]
    y = torch.stack([w[1] for w in warm])
    loss_fn(y.clone().requires_grad_(), y, torch.Generator().manual_seed(0)).backward()
    step, t_cpu0, losses = 0, time.process_time(), []
    t_wall0 = time.perf_counter()
    model.train()
    while time.process_time() - t_cpu0 < budget:
        items = [ds[step * b + k] for k in range(b)]
        img = torch.stack([i[0] for i in items])
        maps = torch.stack([i[1] for i in items])
        loss = loss_fn(model(img), maps, gen)
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(loss.item())
        step += 1
    wall = time.perf_counter() - t_wall0
    res = evaluate(model, src, test_idx, cfg.data.crop, means, 8, seed)
    m = res["model"]
    return {"base_width": base, "max_width": 8 * base, "parameters": count_parameters(model), "steps": step,
            "cpu_s": round(time.process_time() - t_cpu0, 1), "wall_s": round(wall, 1),
            "train_loss_last50": float(np.mean(losses[-50:])), "heldout": m,
            "heldout_mean": float(np.mean([m[c] for c in COLUMNS])),
            "baselines": {k: res[k] for k in ("input_as_diffuse", "dataset_mean")}}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--widths", type=int, nargs="+", default=[8, 16, 32])
    ap.add_argument("--budget", type=float, default=240.0, help="CPU seconds of training per width")
    ap.add_argument("--samples", type=int, default=400)
    ap.add_argument("--lr", type=float, default=2e-4)
    ap.add_argument("--tol", type=float, default=0.05)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "width.json"))
    a = ap.parse_args(argv)
    torch.set_num_threads(a.threads)
    t0 = time.time()
    src = SyntheticSource(a.samples, 144, n_materials=1000, seed=0, kind="presets")
    train_idx, test_idx = split_by_source(src, 0.2, 0)
    means = train_means(src, train_idx, 128, 0)
    rows = []
    for w in sorted(a.widths):
        r = run_width(w, src, train_idx, test_idx, means, a.budget, a.lr, 0)
        print(json.dumps({k: r[k] for k in ("base_width", "steps", "heldout_mean")}), flush=True)
        rows.append(r)
    chosen = rows[-1]["base_width"]
    for small, large in zip(rows, rows[1:]):
        if small["heldout_mean"] <= large["heldout_mean"] * (1 + a.tol):
            chosen = small["base_width"]
            break
    out = {"benchmark": "bench_width", "budget_cpu_s": a.budget, "lr": a.lr, "tolerance": a.tol,
           "data": {"kind": "presets", "samples": a.samples, "size": 144, "crop": 128,
                    "train": int(len(train_idx)), "heldout": int(len(test_idx))},
           "threads": a.threads, "machine": platform.processor() or platform.machine(),
           "rows": rows, "chosen_base_width": chosen, "total_wall_s": round(time.time() - t0, 1),
           "rule": "smallest width whose held-out mean RMSE is within tolerance of the next larger width"}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(out, indent=2) + "\n")
    print(f"chosen base width: {chosen} -> {a.out}")


if __name__ == "__main__":
    main()
