"""Can the compact network learn normals from these images at all, and which objective teaches them fastest? (#4)

Trains the compact default (width 8) on the dvc renders store's training split for a fixed number of steps with one
of several objectives, then measures its normals on held-out and training views (``probe_normals.prediction_stats``:
normal RMSE against the flat normal's, predicted detail energy and correlation with the true detail):

- ``normal_l1``: L1 on the predicted normal x, y only (no rendering loss): can the images teach normals directly?
- ``normal_l2``: the same with a squared error (RMSE is the metric; L1 pulls an uncertain tilt to its median, flat);
- ``render``: the paper's rendering loss alone (``svtrain fit``'s objective with ``optim.normal_l2=0``);
- ``render+normal_l2=W``: the rendering loss plus ``optim.normal_l2=W``, the term ``svtrain fit`` adds.

The same seed, batches, init and optimiser (the compact preset's lr, cosine schedule and clipping) for every
objective; only the loss differs.

    python3 experiments/normal_supervision/probe_normal_supervision.py    # -> results/normal_supervision.json
    python3 experiments/normal_supervision/probe_normal_supervision.py --steps 200 --objectives normal_l2 render
        # a quicker look
"""
from __future__ import annotations

import json
import multiprocessing
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import torch

from train.config import resolve
from train.data import PairDataset, make_loader, open_source, split_by_source
from train.fit import build, lr_at, train_step
from train.loss import make_loss

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import ROOT, parser, timed, write_results  # noqa: E402

#: this experiment's frozen results (experiments/normal_supervision/results/)
RESULTS = Path(__file__).resolve().parent / "results"
from probe_normals import prediction_stats

OBJECTIVES = ("normal_l1", "normal_l2", "render", "render+normal_l2=100")


def run(objective: str, store: str, steps: int, every: int) -> dict:
    torch.set_num_threads(2)
    weight = float(objective.split("=", 1)[1]) if objective.startswith("render+normal_l2=") else 0.0
    cfg = resolve("compact", None, {"data.store": store, "optim.iterations": steps, "optim.normal_l2": weight})
    src = open_source(cfg.data)
    train_idx, test_idx = split_by_source(src, cfg.data.holdout, cfg.optim.seed)
    model, opt, gen = build(cfg)
    ds = PairDataset(src, train_idx, cfg.data.crop, cfg.optim.seed, train=True, flips=cfg.data.augment)
    loss_fn = make_loss(cfg.optim.compile_loss) if objective.startswith("render") else None
    o = cfg.optim
    model.train()

    def train() -> list[float]:
        losses = []
        for step, (img, maps) in enumerate(make_loader(ds, o.batch_size, 0, steps, cfg.data.workers)):
            if loss_fn is not None:
                loss, _ = train_step(model, opt, loss_fn, img, maps, gen, o, step)
            else:  # the same schedule and clipping as train_step, a direct loss on the normals instead of renderings
                for group in opt.param_groups:
                    group["lr"] = lr_at(o, step)
                d = model(img)[:, 0:2] - maps[:, 0:2]
                value = d.abs().mean() if objective == "normal_l1" else (d * d).mean()
                opt.zero_grad(set_to_none=True)
                value.backward()
                torch.nn.utils.clip_grad_norm_(model.parameters(), o.grad_clip)
                opt.step()
                loss = float(value.detach())
            losses.append(loss)
        return losses

    losses, _, train_s = timed(train)
    model.eval()
    return {"objective": objective, "steps": steps, "train_s": round(train_s, 1),
            "loss_last_100": float(np.mean(losses[-100:])),
            "heldout": prediction_stats(model, src, test_idx[::every], cfg.data.crop),
            "train": prediction_stats(model, src, train_idx[::every * 20], cfg.data.crop)}


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--store", default=str(ROOT / "data" / "renders.zarr"))
    ap.add_argument("--steps", type=int, default=800)
    ap.add_argument("--objectives", nargs="+", default=list(OBJECTIVES))
    ap.add_argument("--every", type=int, default=4, help="every k-th held-out view (training: every 20k-th)")
    ap.add_argument("--out", default=str(RESULTS / "normal_supervision.json"))
    a = ap.parse_args(argv)
    bad = [x for x in a.objectives if x not in OBJECTIVES and not x.startswith("render+normal_l2=")]
    if bad:
        ap.error(f"unknown objective(s) {', '.join(bad)}; known: {', '.join(OBJECTIVES)}")
    rows = []
    for obj in a.objectives:
        # one spawned process per objective: a process that has run drjit (the previous objective's evaluation reads
        # maps through it) must not fork loader workers (they hang; see experiments/train_budget/bench_train_budget.prepare_eval)
        with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as ex:
            rows.append(ex.submit(run, obj, a.store, a.steps, a.every).result())
        print(json.dumps(rows[-1]), flush=True)
    write_results(a.out, {"store": a.store, "runs": rows}, a.note)
    print("objective                  held-out normal RMSE (flat)   correlation   train RMSE (flat)")
    for r in rows:
        h, t = r["heldout"], r["train"]
        print(f"{r['objective']:26s} {h['normal_rmse']:.4f} ({h['flat_normal_rmse']:.4f})        "
              f"{h['detail_correlation']:.2f}          {t['normal_rmse']:.4f} ({t['flat_normal_rmse']:.4f})")


if __name__ == "__main__":
    main()
