"""Could a minifying view take one bilinear lookup of prefiltered base maps, in place of ss x ss bilinear
subsamples, and stay as close to the supersampled reference (#42)?

The render stage's transform (:func:`storage.views.transform_planes`) gives a view that minifies (w > 1 base
texels per pixel) ceil(w)^2 bilinear subsamples per pixel: 4 at the default zoom range, which costs about 3.4 times
a magnifying view's one lookup (the gathers are most of it: ``--timing``). This experiment asks whether a cheaper
minification is as accurate, per view kind, against experiments/render_accuracy's references (an 8 x 8
supersampled render, the maps area-averaged over the pixel), with the same 48 views at 64^2.

Candidates (float64 numpy; the base maps blurred on their own texel grid by a separable periodic kernel, then one
bilinear lookup at the pixel centre, normals rotated and renormalised as the stage does; magnifying views
unchanged: one lookup of the unblurred base, as the stage):

* ``var_c``: a kernel of variance c w^2 / 12 per axis (w^2 / 12 is the variance of the pixel's footprint, a w x w
  square, in every direction), made of repeated [a, 1 - 2a, a] passes; c in :data:`VARIANCE_SCALES`;
* ``var_1_levels``: ``var_1`` with w rounded to a grid of 0.1 (a few blurred copies per SVBRDF, made once and
  shared by its views, in place of one blur per view);
* ``box``: the exact overlap of a w-wide interval with each texel's cell (the area average of the piecewise
  constant texture over the footprint, sampled at texel centres);
* ``diag2``, ``diag2_var_1``: two lookups at +-(1/4, 1/4) pixel, without and with the rest of ``var_1``'s blur;
  ``grid2x2``: the stage's own 4 lookups recomputed here, the harness's check (:data:`TWO_LOOKUPS`).

``--timing`` measures, on one drjit thread at the stage's 288^2, the stage's transform of a magnifying (ss = 1) and
a minifying (ss = 2) view, and a numpy 3-tap separable blur of 10 channel planes (what a per-view prefilter adds):
the cost side of the question.

    python3 experiments/minify_prefilter/bench_minify_prefilter.py --timing   # -> results/minify_prefilter.json
"""
from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "render_accuracy"))
from harness import parser, write_results  # noqa: E402
from bench_render_accuracy import KINDS, MAPS, _base, _bilinear, cases, references, rmse_by_kind  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
#: the scales c of the ``var_c`` kernels' variance c w^2 / 12
VARIANCE_SCALES = (0.5, 1.0, 1.5, 2.0, 3.0)


def _conv_periodic(x: np.ndarray, taps: np.ndarray, axis: int) -> np.ndarray:
    """x convolved with symmetric ``taps`` (odd length, centre in the middle) along ``axis``, wrapping."""
    r = len(taps) // 2
    return sum(t * np.roll(x, j - r, axis=axis) for j, t in enumerate(taps))


def kernel_variance(v: float) -> list[np.ndarray]:
    """Passes of [a, 1 - 2a, a] (a <= 1/8) whose convolution has variance v."""
    n = max(1, math.ceil(v / 0.25))
    a = v / (2 * n)
    return [np.array([a, 1 - 2 * a, a])] * n


def kernel_box(w: float) -> list[np.ndarray]:
    """One pass: tap j is the overlap of [-w/2, w/2] with the cell [j - 1/2, j + 1/2], over w."""
    J = math.ceil((w + 1) / 2)
    j = np.arange(-J, J + 1)
    t = np.clip(np.minimum(w / 2, j + 0.5) - np.maximum(-w / 2, j - 0.5), 0.0, None) / w
    return [t]


#: several-lookup patterns: sample offsets in pixels from the pixel centre (picture axes), and the variance scale c
#: of the blur (c w^2 / 12 less the pattern's own variance per axis, 1/16 of a pixel at these offsets); ``grid2x2``
#: is the stage's own pattern at the default zoom range (no blur): the harness's check, it must give the stage's RMSE
TWO_LOOKUPS = {"diag2": (((-0.25, -0.25), (0.25, 0.25)), 0.0),
               "diag2_var_1": (((-0.25, -0.25), (0.25, 0.25)), 1.0),
               "grid2x2": (((-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)), 0.0)}


def kernel(mode: str, w: float) -> list[np.ndarray]:
    if mode in TWO_LOOKUPS:
        c = TWO_LOOKUPS[mode][1]
        v = c * w * w / 12 - w * w / 16
        return kernel_variance(v) if v > 1e-6 else []
    if mode == "box":
        return kernel_box(w)
    if mode == "var_1_levels":
        return kernel_variance(round(w, 1) ** 2 / 12)
    return kernel_variance(float(mode.split("_", 1)[1]) * w * w / 12)


def prefiltered_maps(base, view, res: int, mode: str):
    """A view's maps: bilinear lookups (one, or :data:`TWO_LOOKUPS`' pattern) of the base maps, blurred first where
    the view minifies."""
    from materials.capture import NORMAL_Z_MIN
    from materials.maps import pack_maps, unpack_maps

    b = base.normal.shape[0]
    x = pack_maps(base).astype(np.float64)  # (B, B, 10)
    w = view.zoom * b / res
    if w > 1 + 1e-9:
        for taps in kernel(mode, w):
            x = _conv_periodic(_conv_periodic(x, taps, 0), taps, 1)
    offsets = TWO_LOOKUPS[mode][0] if mode in TWO_LOOKUPS and w > 1 + 1e-9 else ((0.0, 0.0),)
    c, s = math.cos(view.rotation), math.sin(view.rotation)
    out = 0.0
    for dx, dy in offsets:  # picture x right, y up, in pixels
        px = (np.arange(res) + 0.5 + dx) / res
        py = (np.arange(res) + 0.5 - dy) / res
        Y, X = np.meshgrid(0.5 - py, px - 0.5, indexing="ij")
        tu, tv = view.zoom * (c * X + s * Y) + view.shift_u, view.zoom * (-s * X + c * Y) + view.shift_v
        out = out + _bilinear(x, b, tu, tv) / len(offsets)
    n = np.stack([c * out[..., 0] - s * out[..., 1], s * out[..., 0] + c * out[..., 1],
                  np.maximum(out[..., 2], NORMAL_Z_MIN)], -1)
    out[..., :3] = n / np.linalg.norm(n, axis=-1, keepdims=True)
    out[..., 3:] = np.clip(out[..., 3:], 0.0, 1.0)
    return unpack_maps(out.astype(np.float32))


def candidates(res: int, cs: list[dict], mode: str | None) -> tuple[np.ndarray, np.ndarray]:
    """Images (clipped radiance) and maps of each case: the stage's transform (mode None) or a prefilter."""
    from pipeline.render.scene import FlashScene
    from storage.views import ViewParams, transform_maps

    scene = FlashScene(res, 1, "point", "centre")
    imgs, maps = [], []
    for c in cs:
        v = ViewParams(**c["view"])
        b = _base(c["preset"], c["base"])
        m = prefiltered_maps(b, v, res, mode) if mode else transform_maps(b, v, res)
        imgs.append(scene.render_maps(m, v, clip=True))
        maps.append(np.concatenate([getattr(m, k) for k in MAPS], -1))
    return np.stack(imgs), np.stack(maps)


def timing(rounds: int = 5, calls: int = 20) -> dict:
    """Median CPU ms per call, one drjit thread, 288^2 from a 288^2 base: the stage's transform at ss 1 and 2, and
    a numpy 3-tap separable periodic blur of 10 float32 planes (one [a, 1 - 2a, a] pass per axis)."""
    from svcore.mi_env import dr

    from storage.views import ViewParams, texels_of, transform_planes

    b = res = 288
    base = _base(0, b)
    tex = texels_of(base)
    planes = np.random.default_rng(0).random((10, b, b), dtype=np.float32)
    taps = np.array([0.06, 0.88, 0.06], np.float32)
    items = {"transform_ss1": lambda: transform_planes(tex, b, ViewParams(zoom=0.85, rotation=0.7), res),
             "transform_ss2": lambda: transform_planes(tex, b, ViewParams(zoom=1.2, rotation=0.7), res),
             "numpy_blur_3tap": lambda: _conv_periodic(_conv_periodic(planes, taps, 1), taps, 2)}
    times = {k: [] for k in items}
    for f in items.values():
        f()  # compile once
    for _ in range(rounds):
        for k, f in items.items():  # interleaved
            t = time.process_time()
            for _ in range(calls):
                f()
            times[k].append(1000 * (time.process_time() - t) / calls)
    dr.sync_thread()
    return {k: {"median_ms": float(np.median(v)), "rounds_ms": [round(x, 3) for x in v]} for k, v in times.items()}


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--presets", type=int, default=6)
    ap.add_argument("--per-kind", type=int, default=2, help="views per preset and kind")
    ap.add_argument("--timing", action="store_true", help="also time the transform and a numpy blur at 288^2")
    ap.add_argument("--out", default=str(RESULTS / "minify_prefilter.json"))
    a = ap.parse_args(argv)
    from svcore.mi_env import dr

    dr.set_thread_count(1)
    cs = cases(a.res, a.presets, a.per_kind)
    ref_im, ref_mp = references(a.res, cs)
    modes = [None] + [f"var_{c:g}" for c in VARIANCE_SCALES] + ["var_1_levels", "box", *TWO_LOOKUPS]
    arms = {}
    for mode in modes:
        im, mp = candidates(a.res, cs, mode)
        arms[mode or "stage"] = {"image_rmse": rmse_by_kind(cs, im, ref_im), "maps_rmse": rmse_by_kind(cs, mp, ref_mp)}
        print(mode or "stage", json.dumps(arms[mode or "stage"]["image_rmse"]), flush=True)
    stage = arms["stage"]["image_rmse"]
    verdict = {m: {k: r["image_rmse"][k] <= stage[k] for k in KINDS} for m, r in arms.items() if m != "stage"}
    out = {"benchmark": "minify_prefilter", "res": a.res, "presets": a.presets, "views_per_preset_and_kind": a.per_kind,
           "kinds": list(KINDS), "views": len(cs), "arms": arms, "image_at_least_as_close_as_stage": verdict}
    if a.timing:
        out["timing_288"] = timing()
        print(json.dumps(out["timing_288"]))
    write_results(a.out, out, a.note)


if __name__ == "__main__":
    main()
