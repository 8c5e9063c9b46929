"""What `svtrain predict` gives with a checkpoint (default: the bundled model): a contact sheet of views of real and
stress materials.

One row per chosen view: the input photo (sRGB-encoded for display), the four predicted maps in the DESIGN.md
display encodings (:func:`train.predict.map_previews`: normal (n + 1) / 2, diffuse and specular sRGB, roughness as
is), a re-render of the predicted maps under the moved light of ``svtrain predict``'s ``rerender.png``
(:data:`train.predict.MOVED_LIGHT`) and the same re-render of the ground-truth maps (:func:`train.render.flash_render`,
the renderer of the rendering loss and of ``svtrain eval``'s re-render metric). Each row is labelled with the
material (reference rows) or stress category (stress rows) and the view's normal and re-render RMSE, computed as
``svtrain eval`` computes them (:func:`train.evaluate.metrics`: normal in (n + 1) / 2, re-render over its five
lights), so they equal the rows of ``svtrain eval --suite all``'s per_view.csv for those views.

Views go through evaluation's input pipeline (:class:`train.data.PairDataset` with ``train=False``: the centre crop
of the checkpoint's training crop, ``data.crop``, of each stored view) and the checkpoint's network
(:func:`train.checkpoint.load_model`, whose forward decodes the maps, as ``svtrain predict`` runs it).

Views are chosen by seed (stream ``predict_sheet.views``): ``--n-reference`` from the ``--reference`` store, one
per equal stratum of its SVBRDFs (stores list them by material name, so the rows spread over materials), a
random view of each; ``--n-stress`` from the ``--stress`` store, each of another stress category (the unmodified
``reference`` category only when the store has no other).

    python3 benchmarks/bench_predict_sheet.py --reference REF_RENDERS.zarr [--stress data/stress_renders.zarr]
        [--checkpoint bundled] -> docs/img/predict_sheet.png, benchmarks/results/predict_sheet.json

``--reference`` defaults to ``SVGEN_REFERENCE_RENDERS`` (a renders store of ``svgen reference``, e.g. the DVC
pipeline's data/reference/renders.zarr). A missing store is refused in one line (exit 2).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

from harness import IMG, RESULTS, ROOT, parser, write_results

#: environment variable naming the default ``--reference`` store.
REFERENCE_ENV = "SVGEN_REFERENCE_RENDERS"
COLUMNS = ("input photo", "normal", "diffuse", "roughness", "specular", "re-render: predicted",
           "re-render: truth")
#: heights in pixels of the title band, the column header band and each row's label band.
TITLE_PX, HEADER_PX, LABEL_PX = 18, 16, 16
FONT_PX = 11


class Refused(Exception):
    """Bad input: one line, exit 2."""


def layout(tile: int, rows: int) -> dict:
    """Where everything sits on the sheet: tiles of ``tile`` px in len(COLUMNS) columns; above them a title band
    and a column header band; above every row a label band. Row r's tiles start at ``row_y[r]``."""
    top = TITLE_PX + HEADER_PX
    return {"tile": tile, "columns": list(COLUMNS), "rows": rows, "width": tile * len(COLUMNS),
            "height": top + rows * (LABEL_PX + tile),
            "row_y": [top + r * (LABEL_PX + tile) + LABEL_PX for r in range(rows)]}


def text_band(text: str, width: int, height: int, centre: bool = False) -> np.ndarray:
    """(height, width, 3) values in [0, 1]: dark text on white (Pillow's default font at :data:`FONT_PX`)."""
    from PIL import Image, ImageDraw, ImageFont

    im = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(im)
    font = ImageFont.load_default(size=FONT_PX)
    x = max(0, (width - draw.textlength(text, font=font)) / 2) if centre else 3
    draw.text((x, (height - FONT_PX) / 2 - 1), text, fill=(20, 20, 20), font=font)
    return np.asarray(im, np.float64) / 255.0


def stratified_views(src, n: int, seed: int) -> list[int]:
    """``n`` views of ``n`` different SVBRDFs: one SVBRDF from each of n equal strata of the store's SVBRDFs, a
    random view of it (seeded)."""
    per, n_svbrdf = src.views, src.n_svbrdf
    if n > n_svbrdf:
        raise Refused(f"--n-reference {n}: the reference store holds only {n_svbrdf} SVBRDFs")
    rng = _rng(seed, 0)
    edges = np.linspace(0, n_svbrdf, n + 1).round().astype(int)
    return [int(rng.integers(lo, hi)) * per + int(rng.integers(0, per)) for lo, hi in zip(edges[:-1], edges[1:])]


def category_views(src, n: int, seed: int) -> list[tuple[int, str]]:
    """``n`` (view, category) of ``n`` different stress categories (seeded order, a random view in each)."""
    cats = src.categories_of_views()
    names = [c for c in dict.fromkeys(cats) if c is not None]
    if not names:
        raise Refused("the --stress store holds no stress categories (render a `svgen stress` store)")
    # 'reference' is the unmodified material of the stress suite: the failure categories say more
    pool = [c for c in names if c != "reference"] or names
    if n > len(pool):
        raise Refused(f"--n-stress {n}: the stress store has only {len(pool)} categories to show "
                      f"({', '.join(pool)})")
    rng = _rng(seed, 1)
    out = []
    for c in [pool[k] for k in sorted(rng.permutation(len(pool))[:n])]:
        idx = [i for i, x in enumerate(cats) if x == c]
        out.append((idx[int(rng.integers(0, len(idx)))], c))
    return out


def _rng(seed: int, store: int) -> np.random.Generator:
    from svcore.seeds import stream_rng

    return stream_rng(seed, "predict_sheet.views", store)


def material_name(src, i: int) -> str:
    """The material a reference view shows: its preset names without the ``imported/`` prefix."""
    presets = src.source(i)["presets"]
    return " + ".join(p.split("/", 1)[-1] for p in presets) or f"svbrdf {i // src.views}"


def predict_rows(model, src, views: list[int], crop: int, seed: int):
    """Run the network on ``views`` of ``src`` as ``svtrain eval`` feeds them.

    Returns:
        (tiles, metrics): tiles (V, len(COLUMNS)) list of (crop, crop, 3) display images; metrics
        {column: (V,) RMSE} of :func:`train.evaluate.metrics`.
    """
    import torch

    from svcore.image_io import srgb_encode
    from train.data import PairDataset
    from train.evaluate import metrics
    from train.predict import MOVED_LIGHT, map_previews
    from train.render import flash_render

    ds = PairDataset(src, views, crop, seed, train=False)
    img = torch.stack([ds[k][0] for k in range(len(ds))])
    gt = torch.stack([ds[k][1] for k in range(len(ds))])
    with torch.no_grad():
        pred = model(img).float()
        light = torch.tensor(MOVED_LIGHT)
        rer_pred, rer_gt = flash_render(pred, light), flash_render(gt, light)
        err = metrics(pred, gt)
    hwc = lambda t: t.permute(1, 2, 0).numpy()  # noqa: E731
    tiles = []
    for k in range(len(views)):
        maps = map_previews(pred[k:k + 1])
        tiles.append([srgb_encode(hwc(img[k])), *(np.broadcast_to(maps[m], (crop, crop, 3)) for m in
                                                   ("normal", "diffuse", "roughness", "specular")),
                      srgb_encode(hwc(rer_pred[k])), srgb_encode(hwc(rer_gt[k]))])
    return tiles, err


def compose(rows: list[tuple[str, list[np.ndarray]]], tile: int, title: str) -> np.ndarray:
    """The sheet as (H, W, 3) values in [0, 1] (:func:`layout`)."""
    lay = layout(tile, len(rows))
    sheet = np.ones((lay["height"], lay["width"], 3))
    sheet[:TITLE_PX] = text_band(title, lay["width"], TITLE_PX)
    for c, name in enumerate(COLUMNS):
        sheet[TITLE_PX:TITLE_PX + HEADER_PX, c * tile:(c + 1) * tile] = text_band(name, tile, HEADER_PX, True)
    for r, (label, tiles) in enumerate(rows):
        y = lay["row_y"][r]
        sheet[y - LABEL_PX:y] = text_band(label, lay["width"], LABEL_PX)
        for c, t in enumerate(tiles):
            sheet[y:y + tile, c * tile:(c + 1) * tile] = np.clip(t, 0.0, 1.0)
    return sheet


def checkpoint_identity(checkpoint: str) -> dict:
    """What model ran: the bundled file's SHA-256, steps and placeholder flag, or a run's path and step."""
    from train import bundled_model
    from train.checkpoint import load

    if bundled_model.is_bundled(checkpoint):
        bundled_model.model_path()  # checked against its manifest (a damaged file is one line)
        info = bundled_model.manifest()
        return {"name": bundled_model.NAME, "sha256": info["sha256"], "steps": info.get("steps"),
                "placeholder": bool(info.get("placeholder"))}
    return {"path": str(Path(checkpoint).resolve()), "step": int(load(checkpoint).get("step", 0))}


def store_info(src, path: str) -> dict:
    meta = (src.attrs or {}).get("svgen", {})
    return {"store": Path(str(path).rstrip("/")).name, "kind": meta.get("kind"), "config_hash": meta.get("config_hash"),
            "views": len(src)}


def open_store(path: str | None, what: str, hint: str):
    if not path:
        raise Refused(f"no {what} renders store given ({hint})")
    if not Path(path).is_dir():
        raise Refused(f"no {what} renders store at {path} ({hint})")
    from storage.renders_store import RendersReader

    return RendersReader(path)


def run(a) -> int:
    ref_src = open_store(a.reference, "reference", f"--reference, or {REFERENCE_ENV}; `svgen reference` writes one")
    stress_src = open_store(a.stress, "stress", "--stress; `svgen stress` then `svgen render` write one") \
        if a.n_stress > 0 else None
    import torch  # after the stores are found: a missing one is refused without loading torch

    from train.checkpoint import load_model

    torch.set_num_threads(1)
    ident = checkpoint_identity(a.checkpoint)
    model, cfg = load_model(a.checkpoint)
    crop = a.crop or cfg.data.crop
    chosen = [(ref_src, "reference", i, material_name(ref_src, i))
              for i in stratified_views(ref_src, a.n_reference, a.seed)]
    if stress_src is not None:
        chosen += [(stress_src, "stress", i, c) for i, c in category_views(stress_src, a.n_stress, a.seed)]
    rows, records = [], []
    for src in dict.fromkeys(c[0] for c in chosen):  # one network call per store
        mine = [c for c in chosen if c[0] is src]
        tiles, err = predict_rows(model, src, [c[2] for c in mine], crop, cfg.optim.seed)
        for k, (_, kind, i, name) in enumerate(mine):
            rec = {"store": kind, "view": i, "svbrdf": i // src.views, "label": name,
                   **{c: float(v[k]) for c, v in err.items()}}
            records.append(rec)
            rows.append((f"{kind}: {name} (view {i})    normal RMSE {rec['normal']:.3f}    "
                         f"re-render RMSE {rec['rerender']:.3f}", tiles[k]))
    from svcore.image_io import write_png
    from train.predict import MOVED_LIGHT

    who = (f"bundled model ({ident['steps']} steps{', placeholder' if ident.get('placeholder') else ''})"
           if "sha256" in ident else f"{Path(a.checkpoint).name} (step {ident['step']})")
    title = (f"svtrain predict: {who}; {crop}x{crop} centre crops as svtrain eval; "
             f"re-renders under the moved light {tuple(MOVED_LIGHT)}")
    image = Path(a.image)
    image.parent.mkdir(parents=True, exist_ok=True)
    write_png(image, compose(rows, crop, title))
    write_results(a.out, {
        "benchmark": "bench_predict_sheet", "checkpoint": ident, "crop": crop, "seed": a.seed,
        "moved_light": list(MOVED_LIGHT), "image": str(image.resolve()), "layout": layout(crop, len(rows)),
        "stores": {"reference": store_info(ref_src, a.reference),
                   **({"stress": store_info(stress_src, a.stress)} if stress_src is not None else {})},
        "rows": records,
        "rmse_definition": "svtrain eval's per-view RMSE (train.evaluate.metrics): normal in (n+1)/2, maps linear, "
                           "re-render over its five lights"}, a.note)
    for r in records:
        print(f"{r['store']:9s} {r['label'][:32]:32s} view {r['view']:4d}  normal {r['normal']:.4f}  "
              f"rerender {r['rerender']:.4f}")
    print(f"wrote {image} and {a.out}")
    return 0


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--checkpoint", default="bundled",
                    help="run directory or checkpoint file (default: bundled, the model shipped in the package)")
    ap.add_argument("--reference", default=os.environ.get(REFERENCE_ENV),
                    help=f"reference renders store of `svgen reference` (default: {REFERENCE_ENV})")
    ap.add_argument("--stress", default=str(ROOT / "data" / "stress_renders.zarr"),
                    help="renders store of `svgen stress` sets (default: data/stress_renders.zarr)")
    ap.add_argument("--n-reference", type=int, default=6, help="rows of reference views")
    ap.add_argument("--n-stress", type=int, default=3, help="rows of stress views, each another category (0: none)")
    ap.add_argument("--seed", type=int, default=0, help="master seed of the view choice")
    ap.add_argument("--crop", type=int, default=None,
                    help="centre crop side (default: the checkpoint's data.crop, as svtrain eval)")
    ap.add_argument("--image", default=str(IMG / "predict_sheet.png"))
    ap.add_argument("--out", default=str(RESULTS / "predict_sheet.json"))
    a = ap.parse_args(argv)
    from svcore.errors import SvgenError

    try:
        if a.n_reference < 1 or a.n_stress < 0 or a.seed < 0:
            raise Refused("--n-reference must be >= 1, --n-stress and --seed >= 0")
        return run(a)
    except (Refused, SvgenError) as e:
        print(f"bench_predict_sheet: {str(e).splitlines()[0]}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
