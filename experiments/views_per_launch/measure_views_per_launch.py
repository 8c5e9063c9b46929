"""Views per Mitsuba launch (#42, #44): CPU time per view of one launch per view against one launch of all 10 views,
in launches of --per-launch views, by resolution and drjit thread count, and how many 8-bit codes differ.

    python3 experiments/views_per_launch/measure_views_per_launch.py [--res 64 128 256 288] [--threads 1 2] \
        [--per-launch 2 5 10]

The render call only (``FlashScene.render_planes_srgb8`` / ``render_views_srgb8``: textures set, light set, one
``mi.render``, the drjit sRGB encoder), on random textures and flashes already in drjit memory: no view transform,
no store. Both arms are timed alternately, ``--rounds`` times each, and the median is kept. Writes
``results/views_per_launch.json``.
"""
from __future__ import annotations

import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
# harness.py stays in benchmarks/; this experiment imports it from there
sys.path.insert(0, str(HERE.parents[1] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

from svcore.mi_env import use_variant  # noqa: E402

use_variant("llvm_ad_rgb")

from svcore.mi_env import dr, mi  # noqa: E402
from pipeline.render.scene import FlashScene  # noqa: E402
from pipeline.render.stage import launch_groups  # noqa: E402


def measure(res: int, threads: int, views: int, per_launch: int, rounds: int) -> dict:
    """``views`` views one by one against in launches of ``per_launch`` (the stage's :func:`launch_groups`)."""
    dr.set_thread_count(threads)
    one = FlashScene(res, 1, "point", "centre")
    groups = launch_groups(views, per_launch)
    scenes = {len(g): FlashScene(res, 1, "point", "centre", views=len(g)) for g in groups if len(g) > 1}
    rng = np.random.default_rng(res)
    planes = []
    for _ in range(views):
        p = rng.uniform(0.1, 0.9, (10, res * res)).astype(np.float32)
        p[0:2] -= 0.5
        planes.append([mi.Float(c) for c in p])
    lights = [tuple(map(float, xy)) for xy in rng.uniform(-0.7, 0.7, (views, 2))]

    def per_view():
        return np.stack([one.render_planes_srgb8(planes[k], lights[k], k) for k in range(views)])

    def launch():
        return np.concatenate([scenes[len(g)].render_views_srgb8([planes[k] for k in g], [lights[k] for k in g], 0)
                               if len(g) > 1 else one.render_planes_srgb8(planes[g[0]], lights[g[0]], g[0])[None]
                               for g in groups])

    a, b = per_view(), launch()  # compiles both kernels
    d = np.abs(a.astype(np.int16) - b.astype(np.int16))
    cpu = {"per_view": [], "launch": []}
    wall = {"per_view": [], "launch": []}
    for _ in range(rounds):
        for name, f in (("per_view", per_view), ("launch", launch)):
            c0, w0 = time.process_time(), time.perf_counter()
            f()
            cpu[name].append((time.process_time() - c0) / views)
            wall[name].append((time.perf_counter() - w0) / views)
    row = {"res": res, "threads": threads, "views": views, "per_launch": per_launch, "rounds": rounds,
           "codes": int(d.size), "codes_differing": int((d > 0).sum()), "max_code_difference": int(d.max())}
    for name in cpu:
        row[f"cpu_ms_per_view_{name}"] = round(1e3 * statistics.median(cpu[name]), 3)
        row[f"wall_ms_per_view_{name}"] = round(1e3 * statistics.median(wall[name]), 3)
    row["launch_over_per_view_cpu"] = round(row["cpu_ms_per_view_launch"] / row["cpu_ms_per_view_per_view"], 3)
    return row


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--res", type=int, nargs="+", default=[64, 128, 256, 288])
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--views", type=int, default=10)
    ap.add_argument("--per-launch", type=int, nargs="+", default=[10], help="views per launch (launch groups)")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--out", default=str(HERE / "results" / "views_per_launch.json"))
    a = ap.parse_args()
    rows = []
    for res in a.res:
        for t in a.threads:
            for p in a.per_launch:
                rows.append(measure(res, t, a.views, p, a.rounds))
                print(json.dumps(rows[-1]), flush=True)
    print(f"wrote {write_results(a.out, {'experiment': 'views_per_launch', 'rows': rows}, a.note)}")


if __name__ == "__main__":
    main()
