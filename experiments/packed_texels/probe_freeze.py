"""What freezing the render launch (``dr.freeze``) would save, and why it is not applied (#42).

On one drjit thread at ``--res``: the stage's launch (``FlashScene.render_planes_srgb8``: render and 8-bit encoding)
against the same launch frozen (traced once, replayed with the scene, an opaque seed and an opaque flash as inputs),
on the views of ``--svbrdfs`` library variants, the two alternating per view. Then the correctness check that
matters: a frozen launch on views whose planes all stay alive (drjit cannot hand a new plane the memory of an old
one), each compared with the unfrozen launch of the same view: first transformed planes, then planes made from
numpy arrays.

    python3 experiments/packed_texels/probe_freeze.py   # -> results/probe_freeze.json
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--res", type=int, default=288)
    ap.add_argument("--svbrdfs", type=int, default=8)
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "probe_freeze.json"))
    a = ap.parse_args(argv)
    import materials
    from svcore.mi_env import use_variant

    use_variant("llvm_ad_rgb")
    from svcore.mi_env import dr, mi
    from materials.capture import CAMERA_DISTANCE
    from pipeline.render.scene import FlashScene
    from pipeline.render.views import R_MAX, R_MIN, draw_views
    from storage.srgb8 import DrjitEncoder, _BUCKETS
    from storage.views import texels_of, transform_planes

    dr.set_thread_count(1)
    res, enc = a.res, DrjitEncoder()
    scene = FlashScene(res, 1, "point", "centre")

    @dr.freeze
    def launch(sc, seed, codes, thr):  # the encoder's arithmetic (storage.srgb8), its tables as inputs
        x = dr.clip(mi.Float(mi.render(sc, seed=seed, spp=1).array), 0.0, 1.0)
        b = mi.UInt32(dr.maximum(mi.Int32(x * _BUCKETS) - 1, 0))
        c = dr.gather(mi.UInt32, codes, b)
        c += mi.UInt32(x >= dr.gather(mi.Float, thr, c))
        c += mi.UInt32(x >= dr.gather(mi.Float, thr, c))
        return c

    def frozen(planes, light, seed):
        scene.set_planes(planes)
        p = mi.Point3f(light[0], light[1], CAMERA_DISTANCE)
        dr.make_opaque(p)
        scene.params["light.position"] = p
        scene.params.update()
        return np.asarray(launch(scene.scene, dr.opaque(mi.UInt32, seed), enc._codes, enc._thr)).astype(
            np.uint8).reshape(res, res, 3)

    def plain(planes, light, seed):
        return scene.render_planes_srgb8(planes, light, seed)

    presets = materials.presets()[:: max(1, len(materials.presets()) // a.svbrdfs)][:a.svbrdfs]
    views = [(texels_of(p.generate(None, res, i)), v) for i, p in enumerate(presets)
             for v in draw_views(0, i, 10, (R_MIN, R_MAX), (0.7, 1.4))]
    ms = {"plain": 0.0, "frozen": 0.0}
    for timed in (False, True):  # the first pass compiles and records
        for base, v in views:
            planes = transform_planes(base, res, v, res)
            for name, fn in (("plain", plain), ("frozen", frozen)):
                t = time.process_time()
                fn(planes, (v.light_x, v.light_y), v.seed)
                ms[name] += (time.process_time() - t) if timed else 0.0
    ms = {k: round(1000 * t / len(views), 3) for k, t in ms.items()}
    recorded = int(launch.n_recordings)
    # planes kept alive: every view's textures in memory of their own
    alive, wrong = [], []
    for k, (base, v) in enumerate(views[:12]):
        alive.append(transform_planes(base, res, v, res))
        got = frozen(alive[-1], (v.light_x, v.light_y), v.seed)
        want = plain(alive[-1], (v.light_x, v.light_y), v.seed)
        wrong.append(int(np.abs(got.astype(int) - want).max()))
    # the same with planes made from numpy arrays (as a caller with its own maps would), also kept alive
    rng = np.random.default_rng(3)
    wrong_np = []
    for k, (base, v) in enumerate(views[:12]):
        p = rng.uniform(0.1, 0.9, (10, res * res)).astype(np.float32)
        p[0:2] -= 0.5
        alive.append([mi.Float(c) for c in p])
        got = frozen(alive[-1], (v.light_x, v.light_y), v.seed)
        want = plain(alive[-1], (v.light_x, v.light_y), v.seed)
        wrong_np.append(int(np.abs(got.astype(int) - want).max()))
    res_ = {"experiment": "packed_texels.probe_freeze", "res": res, "svbrdfs": a.svbrdfs, "views": len(views),
            "drjit_threads": 1, "ms_per_view": ms, "recordings": recorded,
            "planes_alive_max_code_error_per_view": wrong, "numpy_planes_alive_max_code_error_per_view": wrong_np,
            "recordings_after_numpy_planes": int(launch.n_recordings), "note": a.note,
            "command": "python3 experiments/packed_texels/probe_freeze.py " + " ".join(argv or sys.argv[1:])}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res_, indent=1) + "\n")
    print(json.dumps({k: res_[k] for k in ("ms_per_view", "recordings", "planes_alive_max_code_error_per_view",
                                           "numpy_planes_alive_max_code_error_per_view",
                                           "recordings_after_numpy_planes")}))
    return res_


if __name__ == "__main__":
    main()
