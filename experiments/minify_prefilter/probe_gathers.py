"""What the view transform's time is: its texel gathers, and whether another texel layout gathers faster (#42).

Arms, each the stage's transform arithmetic (:func:`storage.views.transform_planes`, copied here with the texel
fetch swapped), at 288^2 from a 288^2 base, one drjit thread, a magnifying (zoom 0.85: 1 subsample) and a
minifying (zoom 1.2: 2 x 2) view:

* ``stage``: :func:`storage.views.transform_planes` itself (48-byte texels, 3 packet gathers of 4 floats a corner);
* ``texel64_4x4``: texels padded to 16 floats (one 64-byte cache line), 4 packet gathers of 4 a corner;
* ``texel64_16``: the same texels, one 16-float gather a corner (``Array44f``);
* ``no_gathers``: the same arithmetic with every gather replaced by a value computed from the index (what the
  transform costs without its memory reads).

Rounds of 20 calls, arms interleaved, the first (compiling) call untimed. The two texel64 arms are checked to give
the stage's floats.

    PYTHONPATH=. python3 experiments/minify_prefilter/probe_gathers.py   # -> results/probe_gathers.json
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


def transform(fetch, view, dr, mi):
    """storage.views.transform_planes's arithmetic (full picture) with the corner fetch ``fetch(idx) -> 10 Floats``."""
    from materials.capture import NORMAL_Z_MIN

    base, res = B, RES
    ss = max(1, math.ceil(view.zoom * base / res - 1e-9))
    pix = dr.arange(mi.UInt32, res * res)
    row = pix // res
    col = pix - row * res
    c, s = dr.opaque(mi.Float, math.cos(view.rotation)), dr.opaque(mi.Float, math.sin(view.rotation))
    zoom = dr.opaque(mi.Float, view.zoom)
    su, sv = dr.opaque(mi.Float, view.shift_u), dr.opaque(mi.Float, view.shift_v)
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
                texel = fetch(idx)
                for k in range(10):
                    acc[k] = dr.fma(texel[k], w, acc[k])
    if ss > 1:
        acc = [a * (1.0 / (ss * ss)) for a in acc]
    n = dr.normalize(mi.Vector3f(c * acc[0] - s * acc[1], s * acc[0] + c * acc[1], dr.maximum(acc[2], NORMAL_Z_MIN)))
    out = [n.x, n.y, n.z] + [dr.clip(a, 0.0, 1.0) for a in acc[3:]]
    dr.eval(*out)
    return out


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", default=str(RESULTS / "probe_gathers.json"))
    a = ap.parse_args(argv)
    from svcore.mi_env import dr, mi

    import drjit

    dr.set_thread_count(1)
    from materials.maps import pack_maps
    from storage.views import ViewParams, texels_of, transform_planes

    import materials

    base = materials.presets()[0].generate(None, B, 0)
    tex = texels_of(base)
    t16 = np.zeros((B * B, 16), np.float32)
    t16[:, :10] = pack_maps(base).reshape(-1, 10)
    buf16 = mi.Float(t16.ravel())
    array44 = getattr(drjit, mi.variant().split("_")[0]).ad.Array44f  # 4 x 4 floats: one 16-float packet

    def fetch_4x4(idx):
        return [g[q] for p in range(4) for g in (dr.gather(mi.Array4f, buf16, idx * 4 + p),) for q in range(4)][:10]

    def fetch_16(idx):
        g = dr.gather(array44, buf16, idx)
        return [g[p][q] for p in range(4) for q in range(4)][:10]

    def fetch_none(idx):
        f = mi.Float(idx) * 1e-9
        return [f + k for k in range(10)]

    views = {"magnifying": ViewParams(zoom=0.85, rotation=0.7, shift_u=0.3, shift_v=0.1),
             "minifying": ViewParams(zoom=1.2, rotation=0.7, shift_u=0.3, shift_v=0.1)}
    out = {}
    for kind, v in views.items():
        arms = {"stage": lambda: transform_planes(tex, B, v, RES),
                "texel64_4x4": lambda: transform(fetch_4x4, v, dr, mi),
                "texel64_16": lambda: transform(fetch_16, v, dr, mi),
                "no_gathers": lambda: transform(fetch_none, v, dr, mi)}
        ref = [np.asarray(p) for p in arms["stage"]()]
        same = {k: all(np.array_equal(r, np.asarray(p)) for r, p in zip(ref, arms[k]()))
                for k in ("texel64_4x4", "texel64_16")}
        arms["no_gathers"]()
        ms = {k: [] for k in arms}
        for _ in range(a.rounds):
            for k, f in arms.items():
                t = time.process_time()
                for _ in range(20):
                    f()
                ms[k].append(1000 * (time.process_time() - t) / 20)
        med = {k: float(np.median(x)) for k, x in ms.items()}
        out[kind] = {"median_ms": med, "rounds_ms": {k: [round(x, 3) for x in v] for k, v in ms.items()},
                     "same_floats_as_stage": same,
                     "gather_share_of_stage": 1.0 - med["no_gathers"] / med["stage"]}
        print(kind, med, same, flush=True)
    write_results(a.out, {"benchmark": "transform_gathers", "res": RES, "base": B, "drjit_threads": 1,
                          "calls_per_round": 20, "views": out}, a.note)


if __name__ == "__main__":
    main()
