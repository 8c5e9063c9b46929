"""Chart 4 data: the torch loss renderer against Mitsuba at increasing samples per pixel (the agreement floor).

For a few presets of the materials library (glossy metal, glossy plastic, dark leather, rough diffuse; default
parameters, base maps 256^2, seed 0), one random view each (pipeline.render.views.draw_view, the data stage's
distribution), at 256^2:

* torch: ``train.render.flash_render`` of the view's maps (pixel centres, as in training and evaluation), and
  the same supersampled 8 x 8 per pixel (maps repeated, averaged before clipping): the pixel integral;
* Mitsuba (``FlashScene``, point flash): the ``independent`` sampler at spp {1, 2, 4, 8, 16, 64} (random
  positions in the pixel: noise that falls as 1/sqrt(spp) towards the pixel integral), and the ``centre``
  sampler at spp {1, 4, 16, 64} (the centres of a k x k grid; k = 1 is the data stage's default and shades
  exactly torch's points: the float32 floor);
* error: relative RMSE = RMSE / RMS(Mitsuba) of the clipped LDR images, per material and pooled over them
  (sqrt(sum err^2 / sum ref^2)); against torch's pixel centres (``rel_rmse``) and against torch's pixel
  integral (``rel_rmse_vs_integral``: what is left when the film's box filter is accounted for);
* time per view: median wall and CPU (all threads of this process) seconds of FlashScene.render_planes
  (params update, render, copy, clip) over repeats; torch's flash_render per view likewise (1 torch thread).

The only systematic difference at pixel centres besides float32: a shading normal that faces away from the
camera (n.v <= 0, normals tilted > ~65 deg, e.g. beach_sand's view) is black in Mitsuba and lit (clamped
cosines, as the paper's original code) in torch; see tests/test_stability.py.

Writes benchmarks/results/agreement.json and .csv, and the chart docs/img/chart_agreement.png (through
benchmarks/charts/agreement.py, which rebuilds it from the JSON alone).
Usage: python3 benchmarks/bench_agreement.py [--quick] [--res 256] [--no-chart].
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from materials import registry
from materials.maps import pack_maps
from pipeline.render.scene import FlashScene, scene_constants
from pipeline.render.views import draw_view
from storage.views import svbrdf_of, texels_of, transform_planes
from svcore.seeds import rng_for
from train.render import flash_render

from harness import IMG, RESULTS, parser, timed, write_csv, write_results

MATERIALS = ("metal/polished_gold", "plastic/glossy_blue", "leather/black_smooth", "ground/beach_sand")
SETTINGS = ([("independent", spp) for spp in (1, 2, 4, 8, 16, 64)]
            + [("centre", spp) for spp in (1, 4, 16, 64)])
BASE = 256
SUPERSAMPLE = 8
CONTRACT = 0.01


def torch_images(maps, view, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Torch renders of screen-space maps: (pixel centres, pixel integral over a k x k grid), clipped, (H, W, 3)."""
    x = torch.from_numpy(pack_maps(maps)).permute(2, 0, 1)[None]
    light = torch.tensor([view.light_x, view.light_y])
    with torch.no_grad():
        centre = flash_render(x, light)
        xs = x.repeat_interleave(k, 2).repeat_interleave(k, 3)
        integral = F.avg_pool2d(flash_render(xs, light, clip=False), k).clamp(0.0, 1.0)
    to_np = lambda t: t[0].permute(1, 2, 0).numpy().astype(np.float64)  # noqa: E731
    return to_np(centre), to_np(integral)


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="2 materials, 1 timing repeat (smoke run)")
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--out", default=str(RESULTS / "agreement"), help="results path without suffix")
    ap.add_argument("--no-chart", action="store_true")
    args = ap.parse_args(argv)
    # One torch thread: with drjit's pool alive in the same process on 2 cores, 2 torch threads made
    # flash_render ~50x slower (0.9 s instead of 16 ms per 256^2 view: the two pools contend).
    torch.set_num_threads(1)
    res, reps = args.res, (1 if args.quick else 3)
    names = MATERIALS[:2] if args.quick else MATERIALS

    cases = []
    for i, name in enumerate(names):
        base = registry.get_preset(name).generate(None, BASE, 0)
        view = draw_view(rng_for(0, "render", i, 0))  # the views of bench_render_quality
        planes = transform_planes(texels_of(base), BASE, view, res)
        maps = svbrdf_of(planes, res)
        (centre, integral), t_cpu, t_wall = timed(lambda: torch_images(maps, view, SUPERSAMPLE), 1)
        _, tc_cpu, tc_wall = timed(lambda: flash_render(torch.from_numpy(pack_maps(maps)).permute(2, 0, 1)[None],
                                                        torch.tensor([view.light_x, view.light_y])), reps)
        cases.append({"material": name, "view": view, "planes": planes, "torch_centre": centre,
                      "torch_integral": integral, "torch_cpu_s": tc_cpu, "torch_wall_s": tc_wall,
                      "filter_bias": float(np.sqrt(np.sum((integral - centre) ** 2) / np.sum(integral ** 2)))})
        print(f"{name}: pixel integral vs pixel centre (torch) {cases[-1]['filter_bias']:.3%}; "
              f"torch {tc_wall * 1e3:.1f} ms/view", flush=True)

    rows = []
    for sampler, spp in SETTINGS:
        scene = FlashScene(res, spp, "point", sampler)
        c0 = cases[0]
        scene.render_planes(c0["planes"], (c0["view"].light_x, c0["view"].light_y), 0)  # compile once
        per, sq = [], {"c": 0.0, "i": 0.0, "ref": 0.0}
        for c in cases:
            v = c["view"]
            img, cpu, wall = timed(lambda: scene.render_planes(c["planes"], (v.light_x, v.light_y), v.seed), reps)
            img = img.astype(np.float64)
            e_c = float(np.sum((c["torch_centre"] - img) ** 2))
            e_i = float(np.sum((c["torch_integral"] - img) ** 2))
            r2 = float(np.sum(img ** 2))
            sq["c"] += e_c
            sq["i"] += e_i
            sq["ref"] += r2
            per.append({"material": c["material"], "rel_rmse": float(np.sqrt(e_c / r2)),
                        "rel_rmse_vs_integral": float(np.sqrt(e_i / r2)), "mitsuba_cpu_s": cpu,
                        "mitsuba_wall_s": wall})
        row = {"sampler": sampler, "spp": spp, "res": res,
               "rel_rmse": float(np.sqrt(sq["c"] / sq["ref"])),
               "rel_rmse_vs_integral": float(np.sqrt(sq["i"] / sq["ref"])),
               "rel_rmse_max": max(p["rel_rmse"] for p in per),
               "mitsuba_cpu_s_per_view": float(np.median([p["mitsuba_cpu_s"] for p in per])),
               "mitsuba_wall_s_per_view": float(np.median([p["mitsuba_wall_s"] for p in per])),
               "per_material": per}
        rows.append(row)
        print(f"{sampler:11s} spp={spp:3d}: vs torch centres {row['rel_rmse']:.3e} (max {row['rel_rmse_max']:.3e}),"
              f" vs torch pixel integral {row['rel_rmse_vs_integral']:.3e}; "
              f"{row['mitsuba_wall_s_per_view'] * 1e3:.1f} ms/view", flush=True)

    floor = next(r for r in rows if r["sampler"] == "centre" and r["spp"] == 1)
    result = {
        "benchmark": "agreement",
        "definition": "rel RMSE = sqrt(sum (torch - mitsuba)^2) / sqrt(sum mitsuba^2), clipped LDR images, "
                      "pooled over materials; torch at pixel centres unless *_vs_integral",
        "contract_rel_rmse": CONTRACT,
        "agreement_floor": {"sampler": "centre", "spp": 1, "rel_rmse": floor["rel_rmse"],
                            "rel_rmse_max": floor["rel_rmse_max"]},
        "res": res, "supersample": SUPERSAMPLE,
        "materials": [{"material": c["material"], "view": c["view"].as_dict(), "filter_bias_rel_rmse":
                       c["filter_bias"], "torch_cpu_s_per_view": c["torch_cpu_s"],
                       "torch_wall_s_per_view": c["torch_wall_s"]} for c in cases],
        "settings": rows,
        "scene": scene_constants(),
        "quick": args.quick,
    }
    out = Path(args.out)
    write_results(out.with_suffix(".json"), result, args.note)
    table = []
    for r in rows:
        key = {"sampler": r["sampler"], "spp": r["spp"], "res": r["res"]}
        table.append({**key, "material": "pooled", "rel_rmse": r["rel_rmse"],
                      "rel_rmse_vs_integral": r["rel_rmse_vs_integral"],
                      "mitsuba_cpu_s_per_view": r["mitsuba_cpu_s_per_view"],
                      "mitsuba_wall_s_per_view": r["mitsuba_wall_s_per_view"]})
        table += [{**key, "material": p["material"], "rel_rmse": p["rel_rmse"],
                   "rel_rmse_vs_integral": p["rel_rmse_vs_integral"], "mitsuba_cpu_s_per_view": p["mitsuba_cpu_s"],
                   "mitsuba_wall_s_per_view": p["mitsuba_wall_s"]} for p in r["per_material"]]
    write_csv(out.with_suffix(".csv"), table)
    print(f"agreement floor (centre, 1 spp): {floor['rel_rmse']:.3e} pooled, {floor['rel_rmse_max']:.3e} max")
    if not args.no_chart:
        from charts.agreement import chart_agreement

        png = chart_agreement(out.with_suffix(".json"), IMG / "chart_agreement.png")
        print("chart:", png)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
