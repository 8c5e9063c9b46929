"""Render quality vs cost: which light model and samples per pixel does `svgen render` need?

For one view of one preset per material class (base maps 256^2), at res 128 and 256:

* reference: sphere flash (the paper's light), stratified sampler, REF_PASSES x 64 spp with different seeds;
  its own noise is estimated from the two halves (RMS(A - B) / 2 for the mean of A and B);
* candidates: light {point, sphere} x independent sampler x spp {1, 2, 4, 8, 16, 64}, plus the point light
  with the deterministic "centre" sampler (spp 1, 4, 16: the centres of a k x k grid) and the stratified
  sampler (spp 4, 16);
* error: relative RMSE of the clipped LDR image against the clipped reference, pooled over the views
  (sqrt(sum err^2 / sum ref^2)); also per view and its max, and the pooled error with the reference noise
  removed in quadrature;
* cost: CPU seconds (all threads of this process) per view of FlashScene.render_planes (params update,
  render, numpy copy, clip), median over repeats; the map transform is excluded (see bench_render.py).

Decision: among the candidates whose pooled relative RMSE is within 1 % of the reference, the cheapest; costs
within 10 % of the cheapest count as ties (timing noise on a shared machine), broken by the lower error.

Writes benchmarks/results/render_quality.json and .csv. Usage: python3 benchmarks/bench_render_quality.py
[--quick] (quick: 3 materials, 2 reference passes; a smoke run, not for decisions).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from materials import registry
from pipeline.render.scene import FlashScene, scene_constants
from pipeline.render.views import draw_view
from storage.views import texels_of, transform_planes
from svcore.seeds import rng_for

from harness import RESULTS, parser, timed, write_csv, write_results

RESOLUTIONS = (128, 256)
REF_PASSES = 8  # x 64 spp = 512 spp, stratified
CANDIDATES = (
    [(light, "independent", spp) for light in ("point", "sphere") for spp in (1, 2, 4, 8, 16, 64)]
    + [("point", "centre", spp) for spp in (1, 4, 16)]
    + [("point", "stratified", spp) for spp in (4, 16)]
)
THRESHOLD = 0.01
BASE = 256


def materials(quick: bool):
    """One preset per class (the first by name), default parameters, base maps 256^2, seed 0."""
    by_class: dict[str, str] = {}
    for p in sorted(registry.presets(), key=lambda p: p.name):
        by_class.setdefault(p.name.split("/")[0], p.name)
    names = list(by_class.values())[: 3 if quick else None]
    return [(n, registry.get_preset(n).generate(None, BASE, 0)) for n in names]


def reference(res: int, planes, view, passes: int) -> tuple[np.ndarray, float]:
    """Converged sphere-light image (clipped) and the relative RMS noise of that estimate."""
    scene = FlashScene(res, 64, "sphere", "stratified")
    imgs = [scene.render_planes(planes, (view.light_x, view.light_y), seed=10_000 + k, clip=False)
            for k in range(passes)]
    a = np.clip(np.mean(imgs[: passes // 2], axis=0), 0, 1)
    b = np.clip(np.mean(imgs[passes // 2:], axis=0), 0, 1)
    ref = np.clip(np.mean(imgs, axis=0), 0, 1)
    noise = float(np.sqrt(np.mean((a - b) ** 2)) / 2 / np.sqrt(np.mean(ref**2)))
    return ref, noise


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=str(RESULTS / "render_quality"), help="results path without suffix")
    args = ap.parse_args(argv)
    passes = 2 if args.quick else REF_PASSES
    mats = materials(args.quick)
    views = [draw_view(rng_for(0, "render", i, 0)) for i in range(len(mats))]
    rows, refs_info = [], []
    for res in RESOLUTIONS:
        planes = [transform_planes(texels_of(m), BASE, v, res) for (_, m), v in zip(mats, views)]
        refs = []
        for (name, _), p, v in zip(mats, planes, views):
            (ref, noise), _, ref_wall = timed(lambda: reference(res, p, v, passes))
            refs.append(ref)
            refs_info.append({"res": res, "material": name, "view": v.as_dict(), "ref_spp": 64 * passes,
                              "ref_rel_noise": noise, "ref_wall_s": ref_wall})
            print(f"ref res={res} {name}: noise {noise:.4%} ({ref_wall:.1f} s)", flush=True)
        ref_noise = float(np.sqrt(np.mean([r["ref_rel_noise"] ** 2 for r in refs_info if r["res"] == res])))
        for light, sampler, spp in CANDIDATES:
            scene = FlashScene(res, spp, light, sampler)
            scene.render_planes(planes[0], (views[0].light_x, views[0].light_y), 0)  # compile once
            errs, sq_err, sq_ref, cpus, walls = [], 0.0, 0.0, [], []
            for p, v, ref in zip(planes, views, refs):
                img, cpu, wall = timed(lambda: scene.render_planes(p, (v.light_x, v.light_y), v.seed), 3)
                e2 = float(np.sum((img - ref) ** 2))
                r2 = float(np.sum(ref**2))
                errs.append(float(np.sqrt(e2 / r2)))
                sq_err += e2
                sq_ref += r2
                cpus.append(cpu)
                walls.append(wall)
            pooled = float(np.sqrt(sq_err / sq_ref))
            row = {"res": res, "light": light, "sampler": sampler, "spp": spp,
                   "cpu_s_per_view": float(np.median(cpus)), "wall_s_per_view": float(np.median(walls)),
                   "rel_rmse": pooled, "rel_rmse_max": max(errs),
                   "rel_rmse_noise_corrected": float(np.sqrt(max(pooled**2 - ref_noise**2, 0.0))),
                   "rel_rmse_per_view": errs}
            rows.append(row)
            print(f"res={res} {light:6s} {sampler:11s} spp={spp:3d}: rel RMSE {pooled:.3%} (max {max(errs):.3%})"
                  f" cpu {row['cpu_s_per_view'] * 1e3:.1f} ms/view", flush=True)
    chosen = {}
    for res in RESOLUTIONS:
        ok = [r for r in rows if r["res"] == res and r["rel_rmse"] <= THRESHOLD]
        if ok:
            cheapest = min(r["cpu_s_per_view"] for r in ok)
            best = min((r for r in ok if r["cpu_s_per_view"] <= 1.1 * cheapest), key=lambda r: r["rel_rmse"])
            chosen[str(res)] = {k: best[k] for k in ("light", "sampler", "spp", "cpu_s_per_view", "rel_rmse",
                                                      "rel_rmse_max")}
    result = {
        "benchmark": "render_quality", "threshold_rel_rmse": THRESHOLD, "chosen": chosen,
        "materials": [n for n, _ in mats], "scene": scene_constants(), "references": refs_info, "candidates": rows,
        "quick": args.quick,
    }
    out = Path(args.out)
    write_results(out.with_suffix(".json"), result, args.note)
    cols = ["res", "light", "sampler", "spp", "cpu_s_per_view", "wall_s_per_view", "rel_rmse", "rel_rmse_max",
            "rel_rmse_noise_corrected"]
    write_csv(out.with_suffix(".csv"), ({c: r[c] for c in cols} for r in rows))
    print("chosen:", json.dumps(chosen))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
