"""What one 288² view's calls cost in one process on one drjit thread, phase by phase (#42).

``--svbrdfs`` SVBRDFs spread over paper-preset variants and blends stores, each rendered as the render stage does
(read and mix, decode, validate, pack, then per view: transform, scene parameters, Mitsuba, 8-bit encode), plus the
zstd-3 compression of its images and maps as the stage's shard writer does it. One untimed pass first (kernel
compilation); CPU ms per view of the timed pass are printed and written to results/phases.json.

    python3 experiments/chunk_buffers/probe_phases.py --variants ../ps2/variants.zarr --blends ../ps2/blends.zarr
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--variants", required=True)
    ap.add_argument("--blends", required=True)
    ap.add_argument("--svbrdfs", type=int, default=40)
    a = ap.parse_args(argv)
    from svcore.mi_env import use_variant

    use_variant("llvm_ad_rgb")
    from numcodecs import Zstd

    from materials.maps import MAP_NAMES
    from pipeline.config import RenderConfig
    from pipeline.render.stage import scene_for
    from pipeline.render.views import R_MAX, R_MIN, draw_views
    from storage.srgb8 import DrjitEncoder
    from storage.svbrdf_store import SVBRDFInputs, decode_maps
    from storage.views import texels_of, transform_planes
    from svcore.config import build
    from svcore.mi_env import dr, mi

    dr.set_thread_count(1)
    cfg = build(RenderConfig, "paper")
    src = SVBRDFInputs((a.variants, a.blends))
    scene, enc, z = scene_for(cfg)(1), DrjitEncoder(), Zstd(3)
    phases = ("read", "decode", "validate", "texels", "transform", "params", "render", "encode8", "zstd")
    t = dict.fromkeys(phases, 0.0)
    views = 0
    for timed in (False, True):
        for s in np.linspace(0, len(src) - 1, a.svbrdfs).astype(int):
            c = [time.process_time()]
            raw = src.read(int(s), int(s) + 1)
            c.append(time.process_time())
            maps = decode_maps({k: raw[k][0] for k in MAP_NAMES})
            c.append(time.process_time())
            maps.validate(normal_tol=1e-3)
            c.append(time.process_time())
            base = texels_of(maps)
            c.append(time.process_time())
            images = []
            for v in draw_views(cfg.seed, int(s), cfg.views, (R_MIN, R_MAX), tuple(cfg.zoom)):
                d = [time.process_time()]
                planes = transform_planes(base, maps.normal.shape[0], v, cfg.res)
                dr.eval(planes)
                dr.sync_thread()
                d.append(time.process_time())
                scene.set_planes(planes)
                scene.set_light(v.light_x, v.light_y)
                scene.params.update()
                d.append(time.process_time())
                img = mi.render(scene.scene, params=scene.params, seed=int(v.seed), spp=scene.spp)
                dr.eval(img)
                dr.sync_thread()
                d.append(time.process_time())
                images.append(enc(img.array))
                d.append(time.process_time())
                if timed:
                    for k, (x, y) in zip(("transform", "params", "render", "encode8"), zip(d, d[1:])):
                        t[k] += y - x
                    views += 1
            e = time.process_time()
            z.encode(np.ascontiguousarray(np.stack(images)))
            for k in MAP_NAMES:
                z.encode(np.ascontiguousarray(raw[k][0]))
            if timed:
                for k, (x, y) in zip(("read", "decode", "validate", "texels"), zip(c, c[1:])):
                    t[k] += y - x
                t["zstd"] += time.process_time() - e
    out = {k: round(v / views * 1e3, 2) for k, v in t.items()}
    out["sum"] = round(sum(out.values()), 2)
    print(out)
    res = Path(__file__).resolve().parent / "results" / "phases.json"
    res.write_text(json.dumps({"ms_per_view": out, "views": views, "svbrdfs": a.svbrdfs,
                               "command": "python3 experiments/chunk_buffers/probe_phases.py "
                                          + " ".join(argv or sys.argv[1:])}, indent=1) + "\n")
    return out


if __name__ == "__main__":
    main()
