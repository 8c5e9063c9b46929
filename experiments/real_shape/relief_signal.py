"""How much true relief does a model's normal map hold, at which scales, and how much false relief? (issue #39)

The normal RMSE of ``svtrain eval`` mixes two things: the relief a model gets right and the relief it invents. This
script separates them on the views ``svtrain eval`` evaluates (centre crops, no augmentation), for each evaluation set
of the real-shape experiment:

- **slope correlation** between the predicted and the true normal's (x, y), pooled over the set's pixels (uncentred:
  the flat map is the zero). A model can beat the flat map in mean squared error only if this is positive; with the
  best amplitude it reaches ``1 - corr²`` of the flat map's MSE, so **an RMSE 10 % below flat needs corr ≥ 0.44**
  and 25 % below needs corr ≥ 0.66.
- **amplitude**: the predicted relief's RMS over the true relief's (1: as much relief as there is).
- **shrinkage**: the normal RMSE (as ``svtrain eval`` computes it) when the predicted (x, y) is scaled by α and z
  re-normalised, for α from 0 (flat) to 1 (the model): the best α says how much of the relief is worth keeping;
  ``alpha_from_train`` is the one chosen on the training views and applied to every set (no evaluated view chooses
  it).
- **bands**: correlation and amplitude per spatial band, the (x, y) split by Gaussian blurs into coarse (σ > 8 px),
  middle (2–8 px) and fine (< 2 px): is the invented relief fine texture read as bumps, or broad shading?

    python3 experiments/real_shape/relief_signal.py --model runs/ft/control --store runs/rs/train/renders.zarr \
        --reference runs/rs/fold0/ref/renders.zarr runs/rs/fold1/ref/renders.zarr --out results/relief_signal.json

Sets: the store's training views (``svtrain eval --suite train``'s spread, first ``--train-views``), its held-out split
(first ``--heldout-views``) and each reference store whole.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from scipy.ndimage import gaussian_filter  # noqa: E402

from train.checkpoint import load, model_from_state  # noqa: E402
from train.data import PairDataset, open_source  # noqa: E402
from train.evaluate import SUITES  # noqa: E402

ALPHAS = np.round(np.linspace(0.0, 1.0, 11), 2)
#: Gaussian σ (px) between the bands: coarse = blur(8), middle = blur(2) - blur(8), fine = x - blur(2)
BAND_SIGMAS = (2.0, 8.0)
#: the aims' RMSE ratios to flat and the correlation each needs (MSE ratio 1 - corr² at the best amplitude)
NEEDED = {f"{int(round((1 - r) * 100))} % below flat": round(float(np.sqrt(1 - r * r)), 3) for r in (0.9, 0.75)}


def bands(xy: np.ndarray) -> dict[str, np.ndarray]:
    """(N, 2, H, W) -> {band: (N, 2, H, W)}; the bands sum to ``xy``."""
    lo, hi = BAND_SIGMAS
    b_small = gaussian_filter(xy, sigma=(0, 0, lo, lo), mode="reflect")
    b_large = gaussian_filter(xy, sigma=(0, 0, hi, hi), mode="reflect")
    return {"coarse": b_large, "middle": b_small - b_large, "fine": xy - b_small}


def encoded_rmse(pred_xy: np.ndarray, gt: np.ndarray) -> np.ndarray:
    """Per-view RMSE of the normal maps encoded to [0, 1] (``train.evaluate.metrics``), the prediction's z rebuilt
    from its (x, y). pred_xy (N, 2, H, W), gt (N, 3, H, W) -> (N,)."""
    z = np.sqrt(np.clip(1.0 - (pred_xy ** 2).sum(1, keepdims=True), 0.0, 1.0))
    pred = np.concatenate([pred_xy, z], 1)
    return np.sqrt((((pred - gt) * 0.5) ** 2).mean((1, 2, 3)))


def corr_amp(p: np.ndarray, g: np.ndarray) -> dict[str, float]:
    pp, gg, pg = float((p * p).sum()), float((g * g).sum()), float((p * g).sum())
    return {"corr": round(pg / max(np.sqrt(pp * gg), 1e-12), 4), "amplitude": round(np.sqrt(pp / max(gg, 1e-12)), 4)}


def collect(model, src, idx, crop: int) -> tuple[np.ndarray, np.ndarray]:
    """(predicted normals, true normals) of the views, each (N, 3, H, W) unit vectors."""
    ds = PairDataset(src, idx, crop, 0, train=False)
    preds, gts = [], []
    with torch.no_grad():
        for lo in range(0, len(ds), 8):
            items = [ds[k] for k in range(lo, min(lo + 8, len(ds)))]
            img = torch.stack([x[0] for x in items])
            preds.append(model(img)[:, 0:3].numpy())
            gts.append(torch.stack([x[1] for x in items])[:, 0:3].numpy())
    return np.concatenate(preds), np.concatenate(gts)


def per_view(p: np.ndarray, g: np.ndarray, gt: np.ndarray) -> dict:
    """Does the model know *how much* relief a view holds? Views split into thirds by their true relief (RMS of the
    true (x, y)): the model's RMSE over flat's in each third, its predicted relief's RMS there, and the rank
    correlation over views of predicted and true relief RMS."""
    from scipy.stats import spearmanr

    rp, rg = np.sqrt((p ** 2).mean((1, 2, 3))), np.sqrt((g ** 2).mean((1, 2, 3)))
    model, flat = encoded_rmse(p, gt), encoded_rmse(np.zeros_like(p), gt)
    edges = np.quantile(rg, [1 / 3, 2 / 3])
    third = np.digitize(rg, edges)
    out = {"rank_corr_relief": round(float(spearmanr(rp, rg)[0]), 4), "thirds": {}}
    for t, name in enumerate(("flattest", "middle", "most_relief")):
        m = third == t
        out["thirds"][name] = {"views": int(m.sum()), "true_relief_rms": round(float(rg[m].mean()), 4),
                               "predicted_relief_rms": round(float(rp[m].mean()), 4),
                               "normal_over_flat": round(float(model[m].mean() / flat[m].mean()), 4),
                               "model_worse_than_flat": round(float((model[m] > flat[m]).mean()), 3)}
    return out


def analyse(pred: np.ndarray, gt: np.ndarray, alpha_train: float | None) -> dict:
    p, g = pred[:, :2].astype(np.float64), gt[:, :2].astype(np.float64)
    flat = encoded_rmse(np.zeros_like(p), gt)
    curve = {float(a): float(encoded_rmse(a * p, gt).mean()) for a in ALPHAS}
    best = min(curve, key=curve.get)
    out = {"views": int(len(p)), "normal": round(float(encoded_rmse(p, gt).mean()), 5),
           "flat": round(float(flat.mean()), 5), **corr_amp(p, g),
           "best_alpha": best, "normal_at_best_alpha": round(curve[best], 5),
           "shrink_curve": {str(a): round(v, 5) for a, v in curve.items()},
           "bands": {}}
    out["normal_over_flat"] = round(out["normal"] / out["flat"], 4)
    out["best_alpha_over_flat"] = round(out["normal_at_best_alpha"] / out["flat"], 4)
    if alpha_train is not None:
        v = float(encoded_rmse(alpha_train * p, gt).mean())
        out["alpha_from_train"] = {"alpha": alpha_train, "normal": round(v, 5), "over_flat": round(v / out["flat"], 4)}
    out["per_view_amplitude"] = per_view(p, g, gt)
    bp, bg = bands(p), bands(g)
    for name in bp:
        e_true = float((bg[name] ** 2).mean() / max((g ** 2).mean(), 1e-12))
        out["bands"][name] = {**corr_amp(bp[name], bg[name]), "share_of_true_relief": round(e_true, 4)}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", action="append", required=True, help="run folder, checkpoint or 'bundled' (repeat)")
    ap.add_argument("--store", required=True, help="the training store (its training views and held-out split)")
    ap.add_argument("--reference", nargs="*", default=[], help="reference renders stores, evaluated whole")
    ap.add_argument("--train-views", type=int, default=100)
    ap.add_argument("--heldout-views", type=int, default=200)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    torch.manual_seed(0)
    res = {"needed_corr": NEEDED, "band_sigmas_px": BAND_SIGMAS, "models": {}}
    out = Path(a.out)
    if out.is_file():
        res = json.loads(out.read_text())
    for m in a.model:
        if m in res["models"]:
            continue
        model, cfg = model_from_state(load(m))
        model.eval()
        sets = {"train_views": SUITES["train"](cfg.data, a.store)["train"],
                "heldout": SUITES["heldout"](cfg.data, a.store)["heldout"]}
        sets = {"train_views": (sets["train_views"][0], sets["train_views"][1][:a.train_views]),
                "heldout": (sets["heldout"][0], sets["heldout"][1][:a.heldout_views])}
        for i, r in enumerate(a.reference):
            src = open_source(cfg.data.model_copy(update={"store": r}))
            sets[f"reference_{i}"] = (src, np.arange(len(src), dtype=np.int64))
        got, alpha = {}, None
        for name, (src, idx) in sets.items():
            pred, gt = collect(model, src, idx, cfg.data.crop)
            got[name] = analyse(pred, gt, alpha)
            if name == "train_views":
                alpha = got[name]["best_alpha"]
            print(m, name, {k: got[name][k] for k in ("normal_over_flat", "corr", "amplitude", "best_alpha",
                                                      "best_alpha_over_flat")},
                  {b: (v["corr"], v["amplitude"]) for b, v in got[name]["bands"].items()},
                  got[name]["per_view_amplitude"], flush=True)
        res["models"][m] = got
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
