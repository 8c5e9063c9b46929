"""How much of a material's relief does one flash photo show? (#39, round 11)

Round 11's fits (``fit_size.py``) found normals the slowest map to fit even on 12 SVBRDFs seen about 200 times
each. This asks the capture itself, with no network: for each view, at its own flash offset, the torch capture renderer
(``train.render.flash_render``, the loss's and Mitsuba's agreed scene) and the photo's 8-bit sRGB codes (the input's
quantisation):

- ``relief_codes``: RMS of photo(true maps) - photo(flat normals), in codes: the relief's footprint in the photo;
- ``texture_codes``: RMS of photo(flat normals) - photo(flat normals, each other map at its view mean): what the
  colour, specular and roughness texture puts there, the signal a network must not read as relief; and the same with
  only the diffuse (``texture_diffuse_codes``) or only the specular and roughness (``texture_spec_rough_codes``) at
  their means;
- ``diffuse_y_mean``, ``diffuse_y_std``: the view's linear diffuse luminance, its mean and spread over the pixels
  (where the texture in the photo comes from);
- per pixel, the 3x2 Jacobian J of the codes with respect to the slope (s_x, s_y) = (n_x, n_y) / n_z (autograd;
  the renderer is per pixel), its singular values s1 >= s2 and directions v1, v2. Where the flash sits at the
  camera, the photo depends on the slope only through N.L and N.H, which to first order see one component of it
  (along the pixel's direction from the light's foot), so s2 << s1: the other component, and its sign, is not in
  the photo to first order. Reported: the median s2 / s1, the share of the true slope energy along v2
  (``weak_share``), and ``strong_only_over_flat``: the normal RMSE of a reader that gets the slope along v1 exactly and
  predicts zero along v2, over the flat map's (the best a reader of first-order shading alone can do);
- ``codes_per_slope``: the median s1, codes per unit slope along the strong direction;
- ``weak_flip_codes``: RMS of photo(true maps) - photo(the slope's v2 component negated at every pixel): how far apart
  the two photos are that a reader would have to tell apart to get that component's sign;
- ``scale_probe``: the same flip over the relief with the slopes scaled by 1, 0.1 and 0.01 (five views of the last
  real fold): where a linear picture would hold, the ratio would be near 0 at every scale.

Sets: training views of the default store (the first 100 of ``svtrain eval --suite train``'s 400), its first 100
held-out views, and every other view of the 32 real CC0 materials (control.py's two fold stores, 160 of 320 views).

    python3 experiments/real_shape/relief_visibility.py --work runs/rs

Results: ``results/relief_visibility.json``.
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

from materials.maps import pack_maps  # noqa: E402
from storage.renders_store import RendersReader  # noqa: E402
from train.config import DataConfig  # noqa: E402
from train.data import open_source, split_for  # noqa: E402
from train.evaluate import TRAIN_SUITE_VIEWS  # noqa: E402
from train.heldout import subset  # noqa: E402
from train.render import flash_render  # noqa: E402

#: views per set: the first 100 of the train suite's, the first 100 held-out views, every other view of each real fold
#: (one view of each material's lights in two; the whole run takes about 2.5 minutes on one thread)
TRAIN_VIEWS, HELDOUT_VIEWS, REF_STEP = 100, 100, 2


def codes(lin: torch.Tensor) -> torch.Tensor:
    """8-bit sRGB codes (unrounded, differentiable) of a linear image in [0, 1]."""
    x = lin.clamp(0.0, 1.0)
    return 255.0 * torch.where(x <= 0.0031308, 12.92 * x, 1.055 * x.clamp(min=1e-12) ** (1 / 2.4) - 0.055)


def with_slopes(maps: torch.Tensor, s: torch.Tensor) -> torch.Tensor:
    """maps (1, 10, H, W) with its normal replaced by normalize(s_x, s_y, 1); s (1, 2, H, W)."""
    n = torch.cat([s, torch.ones_like(s[:, :1])], 1)
    n = n / n.norm(dim=1, keepdim=True)
    return torch.cat([n, maps[:, 3:]], 1)


def view_figures(maps_np: np.ndarray, light: tuple[float, float]) -> dict:
    """The figures of one view. maps_np: (H, W, 10) packed maps."""
    maps = torch.from_numpy(np.ascontiguousarray(maps_np.transpose(2, 0, 1)))[None]
    off = torch.tensor(light, dtype=torch.float32)
    n = maps[:, 0:3] / maps[:, 0:3].norm(dim=1, keepdim=True)
    s_true = n[:, :2] / n[:, 2:3].clamp(min=1e-3)
    flat = with_slopes(maps, torch.zeros_like(s_true))
    mean_others = torch.cat([flat[:, :3], flat[:, 3:].mean(dim=(2, 3), keepdim=True).expand_as(flat[:, 3:])], 1)
    mean_diffuse = flat.clone()  # only the diffuse at its mean: which map the texture comes from
    mean_diffuse[:, 3:6] = flat[:, 3:6].mean(dim=(2, 3), keepdim=True)
    mean_spec_rough = flat.clone()  # only the specular and the roughness at their means
    mean_spec_rough[:, 6:] = flat[:, 6:].mean(dim=(2, 3), keepdim=True)
    with torch.no_grad():
        a, f, u, ud, usr = (codes(flash_render(m, off)) for m in (with_slopes(maps, s_true), flat, mean_others,
                                                                   mean_diffuse, mean_spec_rough))
    relief = float(((a - f) ** 2).mean().sqrt())
    texture = float(((f - u) ** 2).mean().sqrt())
    texture_diffuse = float(((f - ud) ** 2).mean().sqrt())
    texture_spec_rough = float(((f - usr) ** 2).mean().sqrt())
    # per-pixel Jacobian d codes_c / d s (the renderer is per pixel: the gradient of the channel's sum is J's row)
    s = s_true.clone().requires_grad_(True)
    img = codes(flash_render(with_slopes(maps, s), off))
    rows = [torch.autograd.grad(img[:, c].sum(), s, retain_graph=c < 2)[0][0] for c in range(3)]  # 3 x (2, H, W)
    jac = torch.stack(rows).permute(2, 3, 0, 1).reshape(-1, 3, 2)  # (P, 3, 2)
    _, sv, vh = torch.linalg.svd(jac, full_matrices=False)  # sv (P, 2), vh (P, 2, 2): rows v1, v2
    st = s_true[0].permute(1, 2, 0).reshape(-1, 2)
    along = torch.einsum("pkd,pd->pk", vh, st)  # (P, 2): slope along v1, v2
    strong = along[:, :1] * vh[:, 0]  # the slope a strong-direction reader recovers
    n_true = n[0].permute(1, 2, 0).reshape(-1, 3)
    n_strong = torch.cat([strong, torch.ones_like(strong[:, :1])], 1)
    n_strong = n_strong / n_strong.norm(dim=1, keepdim=True)
    # the photo with the weak component's sign flipped: what a reader would have to tell apart to get that sign
    flipped = st - 2.0 * along[:, 1:] * vh[:, 1]
    with torch.no_grad():
        b = codes(flash_render(with_slopes(maps, flipped.reshape(*s_true.shape[2:], 2).permute(2, 0, 1)[None]), off))
    flip = float(((a - b) ** 2).mean().sqrt())
    flat_err = float(((n_true - torch.tensor([0.0, 0.0, 1.0], dtype=n_true.dtype)) ** 2).mean().sqrt())
    strong_err = float(((n_true - n_strong) ** 2).mean().sqrt())
    energy = float((st ** 2).sum())
    y = (maps[0, 3:6] * torch.tensor([0.2126, 0.7152, 0.0722]).reshape(3, 1, 1)).sum(0)  # linear diffuse luminance
    return {"diffuse_y_mean": float(y.mean()), "diffuse_y_std": float(y.std()), "relief_codes": relief,
            "texture_codes": texture, "weak_flip_codes": flip, "texture_diffuse_codes": texture_diffuse,
            "texture_spec_rough_codes": texture_spec_rough, "flat_rmse": flat_err, "strong_only_rmse": strong_err,
            "weak_energy": float((along[:, 1] ** 2).sum()), "energy": energy,
            "s2_over_s1": float((sv[:, 1] / sv[:, 0].clamp(min=1e-12)).median()),
            "codes_per_slope": float(sv[:, 0].median())}


#: a view "has relief" when its flat map's normal RMSE exceeds this (flat views have no share to speak of)
RELIEF_RMSE = 0.01


def set_figures(reader: RendersReader, views: list[int]) -> dict:
    per = []
    for i in views:
        vp = reader.view_params(i)
        per.append(view_figures(pack_maps(reader.maps(i)), (vp.light_x, vp.light_y)))
    a = {k: np.array([p[k] for p in per]) for k in per[0]}
    relief_views = a["flat_rmse"] > RELIEF_RMSE
    return {
        "views": len(views),
        "diffuse_y_mean_median": round(float(np.median(a["diffuse_y_mean"])), 3),
        "diffuse_y_std_median": round(float(np.median(a["diffuse_y_std"])), 4),
        "relief_codes_median": round(float(np.median(a["relief_codes"])), 2),
        "texture_codes_median": round(float(np.median(a["texture_codes"])), 2),
        "texture_diffuse_codes_median": round(float(np.median(a["texture_diffuse_codes"])), 2),
        "texture_spec_rough_codes_median": round(float(np.median(a["texture_spec_rough_codes"])), 2),
        "weak_flip_codes_median": round(float(np.median(a["weak_flip_codes"])), 3),
        "weak_flip_over_relief_median": round(float(np.median(a["weak_flip_codes"][relief_views]
                                                             / a["relief_codes"][relief_views])), 3),
        "relief_over_texture_median": round(float(np.median(a["relief_codes"] / np.maximum(a["texture_codes"], 1e-9))),
                                            3),
        "s2_over_s1_median": round(float(np.median(a["s2_over_s1"])), 3),
        "codes_per_slope_median": round(float(np.median(a["codes_per_slope"])), 1),
        "weak_share_pooled": round(float(a["weak_energy"].sum() / max(a["energy"].sum(), 1e-12)), 3),
        "strong_only_over_flat_mean_rmse": round(float(a["strong_only_rmse"].mean() / a["flat_rmse"].mean()), 3),
        "strong_only_over_flat_views_with_relief": round(
            float(a["strong_only_rmse"][relief_views].mean() / a["flat_rmse"][relief_views].mean()), 3),
        "views_with_relief": int(relief_views.sum()),
    }


def scale_probe(reader: RendersReader, views: list[int], n: int = 5, scales=(1.0, 0.1, 0.01)) -> dict:
    """The flip's RMS over the relief's with every slope scaled by each of ``scales``, median over the first ``n`` of
    ``views`` with relief: a linear photo would give ~0 at every scale, so where the ratio falls with the scale, the
    weak component is seen through the photo's curvature in the slope, not its slope."""
    got: dict[str, list[float]] = {str(k): [] for k in scales}
    for i in views:
        m = pack_maps(reader.maps(i))
        n_ = m[..., 0:3] / np.linalg.norm(m[..., 0:3], axis=-1, keepdims=True)
        if float(np.sqrt(((n_ - np.array([0, 0, 1], np.float32)) ** 2).mean())) <= RELIEF_RMSE:  # as flat_rmse
            continue
        vp = reader.view_params(i)
        for k in scales:
            s = n_[..., :2] / np.maximum(n_[..., 2:3], 1e-3) * k
            v = np.concatenate([s, np.ones_like(s[..., :1])], -1)
            m2 = m.copy()
            m2[..., 0:3] = v / np.linalg.norm(v, axis=-1, keepdims=True)
            f = view_figures(m2, (vp.light_x, vp.light_y))
            got[str(k)].append(f["weak_flip_codes"] / max(f["relief_codes"], 1e-9))
        if len(got[str(scales[0])]) >= n:
            break
    return {"views": len(got[str(scales[0])]),
            "flip_over_relief_median_by_slope_scale": {k: round(float(np.median(v)), 3) for k, v in got.items()}}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--work", default=str(ROOT / "runs" / "rs"), help="control.py's scratch folder")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "relief_visibility.json"))
    ap.add_argument("--store", default=None, help="only the svgen sets, of this renders store (round 12: the soft "
                                                  "arm's, soft_store.py) in place of WORK's; no real sets")
    a = ap.parse_args(argv)
    work = Path(a.work).resolve()
    store = Path(a.store).resolve() if a.store else work / "train" / "renders.zarr"
    refs = [] if a.store else sorted(work.glob("fold*/ref/renders.zarr"))
    if a.store and not store.is_dir():
        raise SystemExit(f"--store {a.store}: no such renders store")
    if not store.is_dir() or not (refs or a.store):
        raise SystemExit(f"{work} has no train/renders.zarr or fold*/ref/renders.zarr: run control.py --phase stores")
    torch.set_num_threads(1)
    src = open_source(DataConfig(store=str(store)))
    train, test = split_for(src, DataConfig(store=str(store)))
    # the train suite's 400 views spread over the training split, then its first 100 (as `--limit 100` takes them)
    spread = subset(train, TRAIN_SUITE_VIEWS)[:TRAIN_VIEWS]
    reader = RendersReader(store)
    res = {"question": "how much of a material's relief does one flash photo show, against its texture, and along "
                       "which slope directions (first order)?",
           "sets": {"train_views": set_figures(reader, [int(i) for i in spread]),
                    "heldout": set_figures(reader, [int(i) for i in test[:HELDOUT_VIEWS]])}}
    for k, ref in enumerate(refs):
        r = RendersReader(ref)
        res["sets"][f"reference_{k}"] = set_figures(r, list(range(0, len(r), REF_STEP)))
    if refs:
        last = RendersReader(refs[-1])
        res["scale_probe"] = scale_probe(last, list(range(0, len(last), REF_STEP)))
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    for name, f in res["sets"].items():
        print(name, f)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
