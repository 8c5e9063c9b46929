"""How close the stage's images and maps are to a supersampled reference, per view kind: today's code against an
earlier commit's (#42).

The reference of a view at ``res``² is rendered at ``K res``² (K = 8: 64 samples over each pixel, on an 8 x 8 grid of
pixel-centre samples) with Mitsuba's ``direct`` integrator, the maps transformed at that resolution (where every view
magnifies: one bilinear lookup of the base maps per sample, the same in every version of the code), and
box-averaged K x K: the image is the pixel's mean radiance (then clipped to [0, 1], the stored LDR), the maps the
area average of the bilinear base maps over the pixel (normals renormalised). A candidate is the stage's own view at
``res``² (:func:`storage.views.transform_planes` and :class:`pipeline.render.scene.FlashScene`, point flash,
pixel-centre sampler, 1 spp) of the code under test.

View kinds (random rotation, shift and light direction; base maps of library presets):

* ``magnifying``: zoom 0.75 (0.75 base texels per pixel);
* ``minifying``: zoom 1.35 (1.35 texels per pixel, the stage's default range at base = res);
* ``minifying_strong``: base maps of 2 res texels, zoom 1.4 (2.8 texels per pixel, a wider ``render.zoom``);
* ``grazing_light``: the flash at the largest offset (``LIGHT_R_MAX``), zoom log-uniform in the default range.

Beside the stage's code, two minifications through a prefiltered pyramid of the base maps (:data:`PYRAMID_MODES`,
:func:`pyramid_maps`, float64 numpy here) are measured against the same references: the candidates #42 proposed.

    python3 experiments/render_accuracy/bench_render_accuracy.py --before <commit>   # -> results/render_accuracy.json

``--before`` renders the candidates of that commit too, in a ``git worktree`` at /tmp (the same script run there as
a subprocess whose PYTHONPATH starts with the worktree), against the same references.
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import ROOT, parser, write_results  # noqa: E402

#: this experiment's frozen results (experiments/render_accuracy/results/)
RESULTS = Path(__file__).resolve().parent / "results"

K = 8
KINDS = ("magnifying", "minifying", "minifying_strong", "grazing_light")
MAPS = ("normal", "diffuse", "specular", "roughness")


def cases(res: int, presets: int, per_kind: int) -> list[dict]:
    """The views: kind, preset index, base resolution, view fields (deterministic)."""
    import materials
    from materials.capture import LIGHT_R_MAX
    from pipeline.render.views import draw_view

    n = len(materials.presets())
    pick = np.linspace(0, n - 1, presets).round().astype(int)
    out = []
    for ki, kind in enumerate(KINDS):
        for p in pick:
            for j in range(per_kind):
                v = draw_view(np.random.default_rng([42, ki, int(p), j])).as_dict()
                base = 2 * res if kind == "minifying_strong" else res
                if kind == "magnifying":
                    v["zoom"] = 0.75
                elif kind == "minifying":
                    v["zoom"] = 1.35
                elif kind == "minifying_strong":
                    v["zoom"] = 1.4
                else:
                    phi = math.atan2(v["light_y"], v["light_x"])
                    v["light_x"], v["light_y"] = LIGHT_R_MAX * math.cos(phi), LIGHT_R_MAX * math.sin(phi)
                out.append({"kind": kind, "preset": int(p), "base": base, "view": v})
    return out


def _base(preset: int, base: int):
    import materials

    return materials.presets()[preset].generate(None, base, preset)


def candidates(res: int, cs: list[dict], pyramid: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The stage's images (raw radiance clipped to [0, 1]) and maps (packed, 10 channels) of each case;
    ``pyramid``: with the maps of :func:`pyramid_maps` in that mode instead of the stage's transform."""
    from pipeline.render.scene import FlashScene
    from storage.views import ViewParams, transform_maps

    scene = FlashScene(res, 1, "point", "centre")
    imgs, maps = [], []
    for c in cs:
        v = ViewParams(**c["view"])
        b = _base(c["preset"], c["base"])
        m = pyramid_maps(b, v, res, pyramid) if pyramid else transform_maps(b, v, res)
        imgs.append(scene.render_maps(m, v, clip=True))
        maps.append(np.concatenate([getattr(m, k) for k in MAPS], -1))
    return np.stack(imgs), np.stack(maps)


def references(res: int, cs: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """The supersampled reference image and area-averaged maps of each case (module docstring)."""
    from pipeline.render.scene import FlashScene, mi, scene_dict
    from storage.views import ViewParams, transform_maps

    hi = K * res
    scene = FlashScene(hi, 1, "point", "centre")
    d = scene_dict(hi, 1, "point", "centre")
    d["integrator"] = {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0}
    scene.scene = mi.load_dict(d)
    scene.params = mi.traverse(scene.scene)
    imgs, maps = [], []
    for c in cs:
        v = ViewParams(**c["view"])
        assert v.zoom * c["base"] / hi < 1  # every reference sample is one bilinear lookup
        m = transform_maps(_base(c["preset"], c["base"]), v, hi)
        img = scene.render_maps(m, v, clip=False).reshape(res, K, res, K, 3).mean((1, 3))
        imgs.append(np.clip(img, 0.0, 1.0))
        pm = np.concatenate([getattr(m, k) for k in MAPS], -1).reshape(res, K, res, K, 10).mean((1, 3))
        pm[..., :3] /= np.linalg.norm(pm[..., :3], axis=-1, keepdims=True)
        maps.append(pm)
    return np.stack(imgs), np.stack(maps)


#: the prefiltered-pyramid minifications measured against the stage's (not used by the stage: see the results)
PYRAMID_MODES = {
    "trilinear": "mipmap: one bilinear lookup in each of the two pyramid levels around log2(texels per pixel), "
                 "blended linearly in the level (2 lookups a pixel)",
    "level_2x2": "ceil(texels per pixel)^2 (1 or 2 per axis) bilinear subsamples in the pyramid level with 1 to 2 "
                 "texels per pixel (the stage's own lookup at the default zoom range; fewer subsamples beyond it)"}


def _area_weights(base: int, size: int) -> np.ndarray:
    """(size, base): coarse texel i is the area average of the fine interval [i r, (i + 1) r), r = base / size."""
    r = base / size
    lo = np.arange(size)[:, None] * r
    j = np.arange(base)[None, :]
    return np.clip(np.minimum(lo + r, j + 1) - np.maximum(lo, j), 0.0, None) / r


def _bilinear(table: np.ndarray, n: int, tu: np.ndarray, tv: np.ndarray) -> np.ndarray:
    """Periodic bilinear lookup of an (n, n, C) level at texture coordinates (tiles), texel centres at the centres
    of the areas they average."""
    cols = tu * n - 0.5 + n / 2
    rows = -tv * n - 0.5 + n / 2
    r0, c0 = np.floor(rows), np.floor(cols)
    fr, fc = (rows - r0)[..., None], (cols - c0)[..., None]
    r0, c0 = r0.astype(np.int64) % n, c0.astype(np.int64) % n
    r1, c1 = (r0 + 1) % n, (c0 + 1) % n
    return (table[r0, c0] * (1 - fr) * (1 - fc) + table[r0, c1] * (1 - fr) * fc + table[r1, c0] * fr * (1 - fc)
            + table[r1, c1] * fr * fc)


def pyramid_maps(base, view, res: int, mode: str):
    """A view's maps by a prefiltered pyramid of the base maps (float64 numpy; :data:`PYRAMID_MODES`): level l is
    the area average of the base into round(B / 2^l) texels per side; magnified views read the base bilinearly."""
    from materials.capture import NORMAL_Z_MIN
    from materials.maps import N_CHANNELS, pack_maps, unpack_maps

    b = base.normal.shape[0]
    x = np.moveaxis(pack_maps(base).astype(np.float64), -1, 0)  # (10, B, B)
    rho = view.zoom * b / res
    lam = math.log2(rho) if rho > 1 else 0.0
    sizes = [b]
    while sizes[-1] > 1:
        sizes.append(max(1, round(b / 2 ** len(sizes))))

    def level(i):
        w = _area_weights(b, sizes[i])
        return np.moveaxis(w @ x @ w.T, 0, -1)

    def coords(ss):
        sub = (np.arange(ss) + 0.5) / ss
        p = (np.arange(res)[:, None] + sub[None, :]).reshape(-1) / res
        Y, X = np.meshgrid(0.5 - p, p - 0.5, indexing="ij")
        c, s = math.cos(view.rotation), math.sin(view.rotation)
        return view.zoom * (c * X + s * Y) + view.shift_u, view.zoom * (-s * X + c * Y) + view.shift_v

    l0 = min(int(math.floor(lam)), len(sizes) - 1)
    if mode == "trilinear" and lam > 0:
        l1 = min(l0 + 1, len(sizes) - 1)
        t = lam - l0 if l1 > l0 else 0.0
        tu, tv = coords(1)
        out = (1 - t) * _bilinear(level(l0), sizes[l0], tu, tv) + t * _bilinear(level(l1), sizes[l1], tu, tv)
    else:
        if mode == "trilinear":
            l0 = 0
        ss = max(1, math.ceil(view.zoom * sizes[l0] / res - 1e-9))
        tu, tv = coords(ss)
        out = _bilinear(level(l0), sizes[l0], tu, tv)
        out = out.reshape(res, ss, res, ss, N_CHANNELS).mean((1, 3))
    c, s = math.cos(view.rotation), math.sin(view.rotation)
    n = np.stack([c * out[..., 0] - s * out[..., 1], s * out[..., 0] + c * out[..., 1],
                  np.maximum(out[..., 2], NORMAL_Z_MIN)], -1)
    out[..., :3] = n / np.linalg.norm(n, axis=-1, keepdims=True)
    out[..., 3:] = np.clip(out[..., 3:], 0.0, 1.0)
    return unpack_maps(out.astype(np.float32))


def rmse_by_kind(cs, got: np.ndarray, ref: np.ndarray) -> dict:
    kinds = np.array([c["kind"] for c in cs])
    return {k: float(np.sqrt(((got[kinds == k] - ref[kinds == k]) ** 2).mean())) for k in KINDS}


def _before(commit: str, res: int, cs: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """The candidates of ``commit``: this script, run in a worktree of it."""
    wt = Path(tempfile.gettempdir()) / f"svgen_accuracy_{commit[:12]}"
    if not wt.exists():
        subprocess.run(["git", "worktree", "add", "--detach", str(wt), commit], cwd=ROOT, check=True,
                       capture_output=True)
    with tempfile.TemporaryDirectory() as tmp:
        spec, out = Path(tmp) / "cases.json", Path(tmp) / "out.npz"
        spec.write_text(json.dumps({"res": res, "cases": cs}))
        env = {**os.environ, "PYTHONPATH": str(wt) + os.pathsep + os.environ.get("PYTHONPATH", "")}
        subprocess.run([sys.executable, str(Path(__file__).resolve()), "--candidates", str(spec), str(out)],
                       cwd=wt, env=env, check=True)
        z = np.load(out)
        return z["images"], z["maps"]


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--presets", type=int, default=6)
    ap.add_argument("--per-kind", type=int, default=2, help="views per preset and kind")
    ap.add_argument("--before", help="commit whose code gives the 'before' figures")
    ap.add_argument("--candidates", nargs=2, metavar=("CASES_JSON", "OUT_NPZ"), help=argparse_hidden())
    ap.add_argument("--out", default=str(RESULTS / "render_accuracy.json"))
    a = ap.parse_args(argv)
    from svcore.mi_env import dr

    dr.set_thread_count(1)
    if a.candidates:  # the subprocess of --before: candidates only
        spec = json.loads(Path(a.candidates[0]).read_text())
        im, mp = candidates(spec["res"], spec["cases"])
        np.savez(a.candidates[1], images=im, maps=mp)
        return
    cs = cases(a.res, a.presets, a.per_kind)
    ref_im, ref_mp = references(a.res, cs)
    im, mp = candidates(a.res, cs)
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    res = {"after": {"code": f"{head} + working tree", "image_rmse": rmse_by_kind(cs, im, ref_im),
                     "maps_rmse": rmse_by_kind(cs, mp, ref_mp)}}
    res["pyramid_candidates"] = {}
    for mode, what in PYRAMID_MODES.items():
        p_im, p_mp = candidates(a.res, cs, pyramid=mode)
        res["pyramid_candidates"][mode] = {"what": what, "image_rmse": rmse_by_kind(cs, p_im, ref_im),
                                           "maps_rmse": rmse_by_kind(cs, p_mp, ref_mp)}
    if a.before:
        b_im, b_mp = _before(a.before, a.res, cs)
        res["before"] = {"code": a.before, "image_rmse": rmse_by_kind(cs, b_im, ref_im),
                         "maps_rmse": rmse_by_kind(cs, b_mp, ref_mp)}
        res["after_at_least_as_close"] = {k: res["after"]["image_rmse"][k] <= res["before"]["image_rmse"][k]
                                          for k in KINDS}
    print(json.dumps(res, indent=1))
    write_results(a.out, {"benchmark": "render_accuracy", "res": a.res, "supersampling": f"{K}x{K}",
                          "presets": a.presets, "views_per_preset_and_kind": a.per_kind, "kinds": list(KINDS),
                          "views": len(cs), **res}, a.note)


def argparse_hidden():
    import argparse

    return argparse.SUPPRESS


if __name__ == "__main__":
    main()
