"""Would the view transform fused into the BSDF's texel lookup render the same floats faster (#42)?

Today a view is two kernels: :func:`storage.views.transform_planes` writes the view's 10 channel planes, then the
render kernel's BSDF (:class:`pipeline.render.bsdf.GGXBSDF`) gathers its pixel's texel back from them, one float per
plane. The fused candidate (:class:`FusedBSDF`, registered here under its own name, not used by the stage) holds the
base texels and the view's transform as opaque kernel inputs, and computes its pixel's transformed texel inside the
render kernel with the transform's own arithmetic (the pixel from the hit's uv, as the nearest lookup finds it).

Arms, at 288^2 from a 288^2 base, one drjit thread, per view: ``two_kernels`` = ``transform_planes`` then
:meth:`~pipeline.render.scene.FlashScene.render_planes_srgb8` (the stage); ``fused`` = the view's transform set on
the fused BSDF, then the same film-free call and encoding. Magnifying (1 subsample) and minifying (2 x 2) views,
rounds of 20 views, arms interleaved, first round dropped. Checks that both give the same 8-bit codes and floats.

    PYTHONPATH=. python3 experiments/fused_transform/probe_fused.py   # -> results/probe_fused.json
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
B = RES = 288


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--out", default=str(RESULTS / "probe_fused.json"))
    a = ap.parse_args(argv)
    from svcore.mi_env import dr, mi

    dr.set_thread_count(1)
    import materials
    from materials.capture import NORMAL_Z_MIN
    from pipeline.render import bsdf as B_
    from pipeline.render.scene import FlashScene, scene_dict
    from storage.views import TEXEL_STRIDE, ViewParams, supersampling, texels_of, transform_planes

    class FusedBSDF(B_.GGXBSDF):
        """GGXBSDF whose texel is its pixel's texel of the view: the transform computed in the render kernel."""

        def __init__(self, props):
            B_.GGXBSDF.__init__(self, props)
            self.buf = mi.Float(np.zeros(TEXEL_STRIDE, np.float32))
            self.base, self.ss = 1, 1
            self.view = [dr.opaque(mi.Float, 0.0) for _ in range(5)]  # cos, sin, zoom, shift_u, shift_v

        def set_view(self, texels, view, res):
            self.buf, self.base, self.ss = texels.buf, texels.base, supersampling(view, res, texels.base)
            self.view = [dr.opaque(mi.Float, v) for v in (math.cos(view.rotation), math.sin(view.rotation),
                                                          view.zoom, view.shift_u, view.shift_v)]

        def _texel(self, si, active):
            # the nearest lookup's pixel, then transform_planes's arithmetic for that pixel, in the same order
            res, base, ss = self.width, self.base, self.ss
            col = mi.UInt32(dr.clip(mi.Int32(dr.floor(si.uv.x * res)), 0, res - 1))
            row = mi.UInt32(dr.clip(mi.Int32(dr.floor((1.0 - si.uv.y) * res)), 0, res - 1))
            c, s, zoom, su, sv = self.view
            acc = [mi.Float(0.0) for _ in range(10)]
            for i in range(ss):
                for j in range(ss):
                    x = (mi.Float(col) + (j + 0.5) / ss) / res - 0.5
                    y = 0.5 - (mi.Float(row) + (i + 0.5) / ss) / res
                    tu = zoom * (c * x + s * y) + su
                    tv = zoom * (-s * x + c * y) + sv
                    cols = tu * base - 0.5 + base / 2
                    rows = -tv * base - 0.5 + base / 2
                    cols = cols - base * dr.floor(cols / base)
                    rows = rows - base * dr.floor(rows / base)
                    c0f, r0f = dr.floor(cols), dr.floor(rows)
                    fc, fr = cols - c0f, rows - r0f
                    c0 = mi.UInt32(dr.clip(mi.Int32(c0f), 0, base - 1))
                    r0 = mi.UInt32(dr.clip(mi.Int32(r0f), 0, base - 1))
                    c1 = dr.select(c0 + 1 == base, 0, c0 + 1)
                    r1 = dr.select(r0 + 1 == base, 0, r0 + 1)
                    for idx, w in ((r0 * base + c0, (1 - fr) * (1 - fc)), (r0 * base + c1, (1 - fr) * fc),
                                   (r1 * base + c0, fr * (1 - fc)), (r1 * base + c1, fr * fc)):
                        texel = [g[q] for p in range(3) for g in (dr.gather(mi.Array4f, self.buf, idx * 3 + p, active),)
                                 for q in range(4)]
                        for k in range(10):
                            acc[k] = dr.fma(texel[k], w, acc[k])
            if ss > 1:
                acc = [q * (1.0 / (ss * ss)) for q in acc]
            n = dr.normalize(mi.Vector3f(c * acc[0] - s * acc[1], s * acc[0] + c * acc[1],
                                         dr.maximum(acc[2], NORMAL_Z_MIN)))
            d = mi.Color3f(*[dr.clip(q, 0.0, 1.0) for q in acc[3:6]])
            sp = mi.Color3f(*[dr.clip(q, 0.0, 1.0) for q in acc[6:9]])
            r = dr.clip(acc[9], 0.0, 1.0)
            # then GGXBSDF._texel's own steps on the looked-up values
            n = dr.normalize(mi.Vector3f(n.x, n.y, dr.maximum(n.z, NORMAL_Z_MIN)))
            return n, d, sp, dr.maximum(r * r, B_.ALPHA_MIN)

    mi.register_bsdf("svgen_ggx_fused_probe", lambda props: FusedBSDF(props))
    stage = FlashScene(RES, 1, "point", "centre")
    fused = FlashScene(RES, 1, "point", "centre")
    d = scene_dict(RES, 1, "point", "centre")
    d["plane"]["bsdf"]["type"] = "svgen_ggx_fused_probe"
    fused.scene = mi.load_dict(d)
    fused.params = mi.traverse(fused.scene)
    fbsdf = fused.scene.shapes()[0].bsdf()

    texels = texels_of(materials.presets()[0].generate(None, B, 0))
    views = {"magnifying": [ViewParams(light_x=0.2, light_y=0.1 * k, zoom=0.85, rotation=0.3 * k + 0.1, shift_u=0.05 * k,
                                       seed=k) for k in range(20)],
             "minifying": [ViewParams(light_x=-0.2, light_y=0.1 * k, zoom=1.25, rotation=0.3 * k + 0.2,
                                      shift_v=0.05 * k, seed=k) for k in range(20)]}

    def two_kernels(v):
        return stage.render_planes_srgb8(transform_planes(texels, B, v, RES), (v.light_x, v.light_y), v.seed)

    def one_kernel(v):
        fbsdf.set_view(texels, v, RES)
        fused.set_light(v.light_x, v.light_y)
        fused.params.update()
        return _codes(fused, v.seed)

    def _codes(scene, seed):
        from storage.srgb8 import DrjitEncoder

        if scene._encoder is None:
            scene._encoder = DrjitEncoder()
        return scene._encoder(scene.radiance(seed)).reshape(RES, RES, 3)

    out = {}
    for kind, vs in views.items():
        differing_codes = sum(int((two_kernels(v) != one_kernel(v)).sum()) for v in vs[:4])
        floats_equal = []
        for v in vs[:2]:
            stage.set_planes(transform_planes(texels, B, v, RES))
            stage.set_light(v.light_x, v.light_y)
            stage.params.update()
            fbsdf.set_view(texels, v, RES)
            fused.set_light(v.light_x, v.light_y)
            fused.params.update()
            floats_equal.append(bool(np.array_equal(np.asarray(stage.radiance(v.seed)), np.asarray(fused.radiance(v.seed)))))
        arms = {"two_kernels": two_kernels, "fused": one_kernel}
        ms = {k: [] for k in arms}
        for r in range(a.rounds):
            for name, f in arms.items():
                t = time.process_time()
                for v in vs:
                    f(v)
                if r:
                    ms[name].append(1000 * (time.process_time() - t) / len(vs))
        out[kind] = {"differing_codes_of_4_views": differing_codes, "floats_equal_2_views": floats_equal,
                     "median_ms": {k: float(np.median(x)) for k, x in ms.items()},
                     "fused_minus_two_kernels_ms_per_round": [round(f - g, 3) for f, g in zip(ms["fused"], ms["two_kernels"])],
                     "rounds_ms": {k: [round(x, 3) for x in v] for k, v in ms.items()}}
        print(kind, {k: v for k, v in out[kind].items() if k != "rounds_ms"}, flush=True)
    write_results(a.out, {"benchmark": "fused_transform_probe", "res": RES, "base": B, "drjit_threads": 1,
                          "views_per_round": 20, "views": out}, a.note)


if __name__ == "__main__":
    main()
