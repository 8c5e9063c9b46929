"""Why does the network's normal RMSE sit at the flat-normal baseline? Two measurements (#4, README "Known limits").

1. Does the data carry the normal signal? For views of a renders store whose normals are not nearly flat, the
   relative RMSE between the stored image and the loss renderer's flash render (``train.render.flash_render``) of
   the view's aligned maps: with the stored normals, with flat normals, and with two wrong conventions (y flipped;
   normals rotated by -2x the view rotation, i.e. turned the wrong way). If the stored normals agree far better
   than the others, a network can learn them from the images.
2. What does a trained model predict? On held-out and training views (centre crops, as ``svtrain eval``): normal
   RMSE in the (n+1)/2 encoding against the flat normal's, the energy of the predicted normal detail (xy)
   relative to the true one, their correlation, and the share of the squared error that is a per-image tilt.

    python3 experiments/normal_supervision/probe_normals.py --checkpoint runs/train    # -> results/normals_probe.json
    python3 experiments/normal_supervision/probe_normals.py --checkpoint bundled --store data/renders.zarr \
        --reference REF/renders.zarr --out experiments/normal_supervision/results/normals_probe_bundled.json
        # + real, by octave
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import torch

from train.checkpoint import load_model
from train.data import PairDataset, open_source, packed_maps, split_by_source
from train.render import flash_render

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import ROOT, parser, write_results  # noqa: E402

#: this experiment's frozen results (experiments/normal_supervision/results/)
RESULTS = Path(__file__).resolve().parent / "results"


def data_signal(src, n: int, seed: int, min_energy: float = 0.005) -> dict:
    """Relative RMSE of the loss renderer's re-render of each view's maps against its stored image, per variant."""
    rng = np.random.default_rng(seed)
    out = {"true": [], "flat": [], "y_flipped": [], "rotated_wrong_way": []}
    for i in rng.choice(len(src), n, replace=False):
        mp = torch.from_numpy(packed_maps(src, int(i))).permute(2, 0, 1)[None].float()
        if float((mp[0, 0:2] ** 2).mean()) < min_energy:  # nearly flat: normals cannot matter there
            continue
        gt = torch.from_numpy(np.asarray(src.image(int(i)), np.float32)).permute(2, 0, 1)
        v = src.view_params(int(i))
        light = torch.tensor([v.light_x, v.light_y], dtype=torch.float32)

        def rel(maps):
            return float(((flash_render(maps, light)[0] - gt) ** 2).mean().sqrt() / (gt ** 2).mean().sqrt())

        flat, yflip, rot = mp.clone(), mp.clone(), mp.clone()
        flat[:, 0:2], flat[:, 2] = 0.0, 1.0
        yflip[:, 1] = -mp[:, 1]
        c, s = np.cos(2 * v.rotation), np.sin(2 * v.rotation)
        rot[:, 0], rot[:, 1] = c * mp[:, 0] + s * mp[:, 1], -s * mp[:, 0] + c * mp[:, 1]
        for k, m in (("true", mp), ("flat", flat), ("y_flipped", yflip), ("rotated_wrong_way", rot)):
            out[k].append(rel(m))
    return {"views": len(out["true"]), **{f"rel_rmse_{k}": float(np.mean(v)) for k, v in out.items()}}


@torch.no_grad()
def octave_masks(crop: int) -> list[tuple[tuple[int, int], torch.Tensor]]:
    """Radial frequency bands [2^j, 2^(j+1)) cycles per crop (j = 0 .. log2(crop/2) - 1) as (crop, crop) masks of
    the 2-D FFT (the mean, 0 cycles, is the tilt and is left out)."""
    f = torch.fft.fftfreq(crop) * crop
    radius = (f[:, None] ** 2 + f[None, :] ** 2).sqrt()
    bands, lo = [], 1
    while lo < crop // 2:
        bands.append(((lo, 2 * lo), (radius >= lo) & (radius < 2 * lo)))
        lo *= 2
    return bands


def prediction_stats(model, src, indices, crop: int) -> dict:
    """The model's normal detail (the x, y components) against the truth on ``indices`` (centre crops, as eval).

    Besides the totals, per octave of spatial frequency (cycles per crop): the truth's share of detail energy, the
    predicted energy relative to the true one, their correlation, and the gain that would minimise the squared error
    of that band (cross / predicted energy: 1 is right-sized; 0 means the band's prediction is no better than none).
    """
    ds = PairDataset(src, indices, crop, 0, train=False)
    sq = sq_flat = tilt = pg = pp = gg = 0.0
    bands = octave_masks(crop)
    band_pg, band_pp, band_gg = (np.zeros(len(bands)) for _ in range(3))
    for k in range(len(ds)):
        img, gt = ds[k]
        with torch.no_grad():
            p = model(img[None])[0]
        fp, fg = torch.fft.fft2(p[0:2]), torch.fft.fft2(gt[0:2])
        cross, ep, eg = (fp * fg.conj()).real, fp.abs() ** 2, fg.abs() ** 2
        for b, (_, m) in enumerate(bands):
            band_pg[b] += float(cross[:, m].sum())
            band_pp[b] += float(ep[:, m].sum())
            band_gg[b] += float(eg[:, m].sum())
        e = (p[0:3] - gt[0:3]) / 2  # the (n+1)/2 encoding of svtrain eval
        sq += float((e ** 2).mean())
        tilt += float((e.mean((1, 2)) ** 2).mean())
        flat = torch.tensor([0.0, 0.0, 1.0])[:, None, None]
        sq_flat += float((((flat - gt[0:3]) / 2) ** 2).mean())
        dp, dg = p[0:2], gt[0:2]
        pg, pp, gg = pg + float((dp * dg).sum()), pp + float((dp * dp).sum()), gg + float((dg * dg).sum())
    n = len(ds)
    octaves = [{"cycles_per_crop": list(lohi), "true_energy_share": float(band_gg[b] / band_gg.sum()),
                "energy_ratio": float((band_pp[b] / band_gg[b]) ** 0.5), "correlation":
                float(band_pg[b] / (band_pp[b] * band_gg[b]) ** 0.5), "best_gain": float(band_pg[b] / band_pp[b])}
               for b, (lohi, _) in enumerate(bands)]
    return {"views": n, "normal_rmse": (sq / n) ** 0.5, "flat_normal_rmse": (sq_flat / n) ** 0.5,
            "tilt_share_of_mse": tilt / sq, "detail_energy_ratio": (pp / gg) ** 0.5,
            "detail_correlation": pg / (pp * gg) ** 0.5, "octaves": octaves}


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--checkpoint", default=str(ROOT / "runs" / "train"))
    ap.add_argument("--store", default=None, help="renders store (default: the checkpoint's training store)")
    ap.add_argument("--views", type=int, default=60, help="views drawn for the data check")
    ap.add_argument("--every", type=int, default=4, help="every k-th view of each split for the model check")
    ap.add_argument("--reference", default=None, help="a reference renders store (`svgen reference OUT`: "
                    "OUT/renders.zarr, real materials): every view measured as a third split")
    ap.add_argument("--out", default=str(RESULTS / "normals_probe.json"))
    a = ap.parse_args(argv)
    torch.set_num_threads(2)
    model, cfg = load_model(a.checkpoint)
    model.eval()
    if a.store:
        cfg.data.store = a.store
    src = open_source(cfg.data)
    train_idx, test_idx = split_by_source(src, cfg.data.holdout, cfg.optim.seed)
    res = {"checkpoint": a.checkpoint, "store": cfg.data.store, "model": cfg.to_dict()["model"],
           "data_signal": data_signal(src, a.views, 0),
           "heldout": prediction_stats(model, src, test_idx[::a.every], cfg.data.crop),
           "train": prediction_stats(model, src, train_idx[:: a.every * 20], cfg.data.crop)}
    if a.reference:
        ref = open_source(cfg.data.model_copy(update={"store": a.reference}))
        res["reference"] = prediction_stats(model, ref, np.arange(len(ref)), cfg.data.crop)
        res["reference_store"] = Path(a.reference).name
    write_results(a.out, res, a.note)
    print(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
