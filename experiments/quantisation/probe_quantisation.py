"""Does 8-bit storage hide the relief? The relief's imprint on a photo against the quantisation noise (#22).

#22 lists "8-bit image quantisation against 16-bit" among the data factors that might keep the network from
learning shape. Training on a 16-bit store would need a second image encoding in every reader; this probe answers
the question that decides whether that is worth it, from the renders themselves, without training.

For each view of a renders store it renders the view's own maps twice under the view's flash (the store's scene,
linear, clipped to [0, 1] as stored): with their normals, I, and with flat normals, I_flat. The relief's imprint on
the photo is S = I - I_flat. The noise that storage adds to the photo is q_b(I) - I, with q_b the store's
encoding at b bits (8: the stored 8-bit sRGB code, ``storage.srgb8``; 16: the same curve at 65535
steps). Both are measured in the linear image and in the network's input space (``train.net``'s log mapping,
where dark pixels are stretched). The figure of merit per view is the relief-to-quantisation ratio in dB,
10 log10(sum S^2 / sum (q_b(I) - I)^2): far above 0 dB, quantisation cannot be what hides the relief. Beside the
share of views below 10 dB, the summary gives their share of the flat map's squared normal error (what those views
could give the normal metric at most): near-flat relief leaves a faint imprint but also weighs little.

Views whose normals are flat (the flat relief mode, or no relief) have no imprint and are left out (normal RMSE
against flat below ``--min-tilt``).

    python3 experiments/quantisation/probe_quantisation.py --store svgen=DIR/now_r.zarr \
        --store real=W/ref_crop1/renders.zarr
        # -> experiments/quantisation/results/quantisation.json, docs/img/chart_quantisation.png

A store is named NAME=PATH (a renders store: svgen's held-out probe store, the CC0 reference rendered by
bench_sim2real); ``--views`` evenly spaced views of each are measured.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import IMG, parser, pyplot, save_figure, write_results  # noqa: E402

#: this experiment's frozen results (experiments/quantisation/results/)
RESULTS = Path(__file__).resolve().parent / "results"

#: the network's input mapping (train/net.py LOG_EPS): log(x + EPS), up to an affine map that cancels in a ratio
LOG_EPS = 0.01


def quantise(linear: np.ndarray, bits: int) -> np.ndarray:
    """Linear [0, 1] image -> the linear image a store of ``bits``-bit sRGB codes gives back (same shape).

    8 bits is exactly the stored encoding (``encode_srgb8`` / ``decode_srgb8``); 16 bits uses the same curve
    (colour-science, via ``svcore.image_io``) at 65535 steps.
    """
    if bits == 8:
        from storage.srgb8 import decode_srgb8, encode_srgb8

        return decode_srgb8(encode_srgb8(linear))
    from svcore.image_io import srgb_decode, srgb_encode

    top = 2.0 ** bits - 1
    codes = np.round(top * np.asarray(srgb_encode(np.clip(linear, 0.0, 1.0)), np.float64))
    return np.asarray(srgb_decode(codes / top), np.float32)


def imprint_ratio_db(image: np.ndarray, flat: np.ndarray, bits: int, log_space: bool = False) -> float:
    """Relief imprint against quantisation noise, in dB: 10 log10(sum (I - I_flat)^2 / sum (q(I) - I)^2).

    Args:
        image: (H, W, 3) linear render with the relief.
        flat: (H, W, 3) the same view with flat normals.
        bits: 8 or 16.
        log_space: measure both in the network's input space log(x + 0.01) instead of linear.
    """
    f = (lambda x: np.log(np.asarray(x, np.float64) + LOG_EPS)) if log_space else (lambda x: np.asarray(x, np.float64))
    signal = np.sum((f(image) - f(flat)) ** 2)
    noise = np.sum((f(quantise(image, bits)) - f(image)) ** 2)
    if noise == 0:
        return math.inf
    return float(10 * np.log10(max(signal, 1e-30) / noise))


def measure(path: str, views: int, min_tilt: float) -> dict:
    """Per-view ratios (8 and 16 bits, linear and log) of ``views`` evenly spaced views of renders store ``path``."""
    import dataclasses

    from pipeline.render.scene import FlashScene
    from storage.renders_store import RendersReader

    r = RendersReader(path)
    cfg = r.attrs["config"]
    scene = FlashScene(r.res, cfg["spp"], cfg["light"], cfg["sampler"])
    idx = np.unique(np.linspace(0, len(r) - 1, min(views, len(r))).round().astype(int))
    rows = []
    for i in idx:
        maps, view = r.maps(int(i)), r.view_params(int(i))
        tilt = float(np.sqrt(np.mean(((maps.normal - [0.0, 0.0, 1.0]) / 2) ** 2)))
        if tilt < min_tilt:
            continue
        flat_n = np.zeros_like(maps.normal)
        flat_n[..., 2] = 1.0
        image = scene.render_maps(maps, view)
        flat = scene.render_maps(dataclasses.replace(maps, normal=flat_n), view)
        row = {"view": int(i), "normal_rmse_vs_flat": round(tilt, 5),
               "imprint_rms_linear": round(float(np.sqrt(np.mean((image - flat) ** 2))), 6)}
        for bits in (8, 16):
            row[f"db_{bits}_linear"] = round(imprint_ratio_db(image, flat, bits), 2)
            row[f"db_{bits}_log"] = round(imprint_ratio_db(image, flat, bits, log_space=True), 2)
        rows.append(row)
    summary = {}
    # what a view can give the normal metric: the flat map's squared error on it (its relief's whole weight)
    weight = np.array([row["normal_rmse_vs_flat"] for row in rows]) ** 2
    for key in ("db_8_linear", "db_8_log", "db_16_linear", "db_16_log"):
        v = np.array([row[key] for row in rows])
        summary[key] = {"median": round(float(np.median(v)), 2), "p05": round(float(np.quantile(v, 0.05)), 2),
                        "share_below_0db": round(float(np.mean(v < 0)), 4),
                        "share_below_10db": round(float(np.mean(v < 10)), 4),
                        "flat_mse_share_below_10db": round(float(weight[v < 10].sum() / weight.sum()), 4)}
    return {"views_measured": len(rows), "views_flat_skipped": int(len(idx) - len(rows)), "summary": summary,
            "views": rows}


def chart(results: dict, png: Path) -> None:
    """Per store, the histogram of each view's relief-to-quantisation ratio at 8 and 16 bits (log input space)."""
    plt = pyplot()
    names = list(results)
    fig, axes = plt.subplots(1, len(names), figsize=(4.2 * len(names), 3.2), squeeze=False)
    for ax, name in zip(axes[0], names):
        rows = results[name]["views"]
        for bits, colour in ((8, "tab:blue"), (16, "tab:orange")):
            v = [row[f"db_{bits}_log"] for row in rows]
            ax.hist(v, bins=30, range=(-10, 110), alpha=0.6, color=colour, label=f"{bits}-bit")
        ax.axvline(0, color="k", lw=0.8)
        ax.set_title(f"{name}: {len(rows)} views with relief", fontsize=9)
        ax.set_xlabel("relief imprint / quantisation noise (dB, network input space)", fontsize=8)
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, png)


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--store", action="append", required=True, metavar="NAME=PATH", help="a renders store")
    ap.add_argument("--views", type=int, default=200, help="views per store (evenly spaced)")
    ap.add_argument("--min-tilt", type=float, default=0.002,
                    help="leave out views whose normal RMSE against flat ((n+1)/2 encoding) is below this")
    ap.add_argument("--out", default=str(RESULTS / "quantisation.json"))
    ap.add_argument("--png", default=str(IMG / "chart_quantisation.png"))
    a = ap.parse_args(argv)
    stores = {}
    for spec in a.store:
        name, sep, path = spec.partition("=")
        if not sep or not name or not path:
            ap.error(f"--store {spec!r}: expected NAME=PATH")
        stores[name] = path
    results = {}
    for name, path in stores.items():
        results[name] = measure(path, a.views, a.min_tilt)
        s = results[name]["summary"]
        e = s["db_8_log"]
        print(f"{name}: {results[name]['views_measured']} views; median dB 8-bit {e['median']} (log) "
              f"{s['db_8_linear']['median']} (linear); 16-bit {s['db_16_log']['median']} (log); 8-bit views below "
              f"0 dB {e['share_below_0db']:.1%}; below 10 dB {e['share_below_10db']:.1%} of the views, "
              f"{e['flat_mse_share_below_10db']:.1%} of the flat map's squared normal error", flush=True)
    named = {k: "/".join(Path(v).parts[-2:]) for k, v in stores.items()}
    write_results(a.out, {"benchmark": "quantisation", "stores": named, "views": a.views, "min_tilt": a.min_tilt,
                          "results": results}, a.note)
    chart(results, Path(a.png))


if __name__ == "__main__":
    main()
