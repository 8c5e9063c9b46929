"""Does the rendering loss pay the network for copying the photo into its specular map? (#39, round 9)

The models predict a specular map whose luminance follows the diffuse map's (median correlation 0.7-0.77) on
svgen's own training and held-out views, whose ground truth is grey and constant (median 0.00). A data change
cannot remove what the data does not hold, so this asks the loss: on the same views and the same lights, what does
the rendering loss (train/loss.py, the training term) of the model's maps become when only the specular map is
replaced

- ``grey``: by one grey value, the mean luminance of the model's own specular (its texture and colour removed);
- ``truth``: by the ground-truth specular (the oracle);

and, to see whether the copy pays only because the other maps are wrong, the ground truth's normal, diffuse and
roughness with the model's specular (``others_true``) or with its grey mean (``others_true_grey``).

Beside them, what the map terms see of the same specular (means over the views): its L1 to the truth and its grey
mean's (``specular_l1``: an L1 term on the maps weighs the level, not the texture), and ``optim.spec_grad``'s term
(``train.fit.spec_grad_term``) on the model's maps, the scale a weight for it is set against.

Per view: the loss under ``--configs`` x 9 seeded light/view configurations (the training distribution), the same for
every variant. Effect = model - variant (positive: the variant's loss is lower, the loss would pay for it), 95 %
bootstrap over SVBRDFs (``train.evaluate.paired``). If ``grey`` lowers the loss, the copied texture costs loss and
the network is short of fitting it; if it raises it, the copy explains part of the rendered appearance that the
other maps miss, and the loss holds the texture in place.

Usage: python3 experiments/real_shape/spec_sensitivity.py --run RUN --store STORE [--suite train|heldout]
       [--views 100] [--configs 4] [--out results/spec_sensitivity.json --name NAME]
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from train.brdf import SPECULAR
from train.checkpoint import load, model_from_state
from train.config import DataConfig
from train.data import PairDataset, open_source, split_for
from train.evaluate import cluster_ids, paired
from train.fit import spec_grad_term
from train.loss import LossConfigs, rendering_loss, sample_configs
from train.spec_stats import LUMA, spec_stats

VARIANTS = ("grey", "truth", "others_true", "others_true_grey")


def with_specular(pred: torch.Tensor, gt: torch.Tensor, variant: str) -> torch.Tensor:
    """``pred`` (1, 10, H, W) with its specular channels replaced as ``variant`` says (module docstring)."""
    if variant.startswith("others_true"):  # the truth's other maps under the model's specular (or its grey mean)
        out = gt.clone()
        out[:, SPECULAR] = with_specular(pred, gt, "grey")[:, SPECULAR] if variant.endswith("grey") else pred[:, SPECULAR]
        return out
    out = pred.clone()
    if variant == "grey":
        y = (pred[:, SPECULAR] * torch.tensor(LUMA, dtype=pred.dtype)[None, :, None, None]).sum(1).mean()
        out[:, SPECULAR] = y
    elif variant == "truth":
        out[:, SPECULAR] = gt[:, SPECULAR]
    else:
        raise ValueError(variant)
    return out


def views_of(data: DataConfig, suite: str, n: int) -> tuple:
    """The store's ``suite`` split and ``n`` of its views spread evenly (as eval's train suite spreads them)."""
    src = open_source(data)
    train, test = split_for(src, data if suite == "train" else data.model_copy(update={"blends": True}))
    idx = train if suite == "train" else test
    return src, idx[np.linspace(0, len(idx) - 1, min(n, len(idx))).round().astype(np.int64)]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--run", required=True, help="run folder (its model.pt) or 'bundled'")
    ap.add_argument("--store", required=True, help="renders store whose views are evaluated")
    ap.add_argument("--suite", choices=("train", "heldout"), default="train")
    ap.add_argument("--views", type=int, default=100)
    ap.add_argument("--configs", type=int, default=4, help="seeded draws of the 9 training configurations per view")
    ap.add_argument("--out", default=None, help="results JSON (its other keys kept)")
    ap.add_argument("--name", default=None, help="key in --out [default: RUN's folder name and the suite]")
    a = ap.parse_args(argv)
    torch.set_num_threads(1)
    model, cfg = model_from_state(load(a.run))
    src, idx = views_of(cfg.data.model_copy(update={"store": a.store}), a.suite, a.views)
    ds = PairDataset(src, idx, cfg.data.crop, 0, train=False)
    losses = {v: [] for v in ("model",) + VARIANTS}
    corr, l1, l1_grey, grad = [], [], [], []
    with torch.no_grad():
        for k in range(len(ds)):
            img, gt = (t[None] for t in ds[k][:2])
            pred = model(img)
            gen = torch.Generator().manual_seed(int(idx[k]))  # same lights for every variant of a view
            draws = [sample_configs(1, gen) for _ in range(a.configs)]
            lc = LossConfigs(torch.cat([d.light for d in draws], 1), torch.cat([d.view for d in draws], 1))
            losses["model"].append(float(rendering_loss(pred, gt, cfg=lc)))
            for v in VARIANTS:
                losses[v].append(float(rendering_loss(with_specular(pred, gt, v), gt, cfg=lc)))
            corr.append(float(spec_stats(pred)["spec_diffuse_corr"][0]))
            l1.append(float((pred[:, SPECULAR] - gt[:, SPECULAR]).abs().mean()))
            grey = with_specular(pred, gt, "grey")
            l1_grey.append(float((grey[:, SPECULAR] - gt[:, SPECULAR]).abs().mean()))
            grad.append(float(spec_grad_term(pred, gt)))
    cl = cluster_ids(src, idx)
    base = np.array(losses["model"])
    res = {"run": a.run if a.run == "bundled" else Path(a.run).name, "suite": a.suite, "views": len(ds),
           "svbrdfs": int(len(set(cl.tolist()))), "configs_per_view": 9 * a.configs,
           "model_spec_diffuse_corr_median": round(float(np.median(corr)), 3),
           "loss": {v: round(float(np.mean(x)), 5) for v, x in losses.items()},
           "specular_l1": {"model": round(float(np.mean(l1)), 5), "grey": round(float(np.mean(l1_grey)), 5)},
           "spec_grad_term": round(float(np.mean(grad)), 5)}
    for v in ("grey", "truth"):
        p = paired(np.array(losses[v]), base, cl, seed=0)  # gain = model - variant
        res[f"model_minus_{v}"] = {"gain": round(p["gain"], 5), "ci95": [round(x, 5) for x in p["ci95"]]}
    # with the truth's other maps: does the model's specular cost loss against its own grey mean?
    p = paired(np.array(losses["others_true_grey"]), np.array(losses["others_true"]), cl, seed=0)
    res["others_true_minus_others_true_grey"] = {"gain": round(p["gain"], 5), "ci95": [round(x, 5) for x in p["ci95"]]}
    print(json.dumps(res, indent=1))
    if a.out:
        out = Path(a.out)
        got = json.loads(out.read_text()) if out.is_file() else {}
        got[a.name or f"{res['run']}_{a.suite}"] = res
        out.write_text(json.dumps(got, indent=1) + "\n")


if __name__ == "__main__":
    main()
