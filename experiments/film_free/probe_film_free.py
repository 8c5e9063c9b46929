"""The render call with and without Mitsuba's film, one thread, same floats (#42).

Times :meth:`pipeline.render.scene.FlashScene.render_film` (``mi.render`` through the film) against the film-free
:meth:`~pipeline.render.scene.FlashScene.radiance` (the stage's path at one sample per pixel), each followed by the
stage's 8-bit encoding and preceded by setting the textures and the flash, as the stage does per view; rounds of 20
calls, the two arms interleaved, the first round dropped (kernel compilation); one drjit thread. Checks that the two
give the same floats on random textures, lights and seeds.

    PYTHONPATH=. python3 experiments/film_free/probe_film_free.py   # -> results/probe_film_free.json
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--res", type=int, default=288)
    ap.add_argument("--rounds", type=int, default=8)
    ap.add_argument("--out", default=str(RESULTS / "probe_film_free.json"))
    a = ap.parse_args(argv)
    from svcore.mi_env import dr, mi

    dr.set_thread_count(1)
    from pipeline.render.scene import FlashScene
    from storage.srgb8 import DrjitEncoder

    res, enc, out = a.res, DrjitEncoder(), {}
    for sampler, light in (("centre", "point"), ("independent", "point"), ("centre", "sphere")):
        sc = FlashScene(res, 1, light, sampler)
        rng = np.random.default_rng(1)
        differing = 0
        for t in range(4):
            planes = [mi.Float(rng.random(res * res).astype(np.float32)) for _ in range(10)]
            planes[2] = mi.Float((0.5 + 0.5 * rng.random(res * res)).astype(np.float32))  # normals facing out
            lx, ly = (float(v) for v in rng.uniform(-0.5, 0.5, 2))
            sc.set_planes(planes)
            sc.set_light(lx, ly)
            sc.params.update()
            differing += int((np.asarray(sc.render_film(t)) != np.asarray(sc.radiance(t))).sum())
        arms = {"film": sc.render_film, "film_free": sc.radiance}
        ms = {k: [] for k in arms}
        for r in range(a.rounds):
            for name, f in arms.items():
                t0 = time.process_time()
                for i in range(20):
                    sc.set_planes(planes)
                    sc.set_light(0.1, 0.2)
                    sc.params.update()
                    enc(f(i))
                if r:
                    ms[name].append(1000 * (time.process_time() - t0) / 20)
        key = f"{light}_{sampler}"
        out[key] = {"differing_floats": differing, "values_compared": 4 * res * res * 3,
                    **{f"{k}_ms_median": float(np.median(v)) for k, v in ms.items()},
                    "film_free_minus_film_ms_per_round": [round(f - g, 3) for f, g in zip(ms["film_free"], ms["film"])],
                    "rounds_ms": {k: [round(x, 3) for x in v] for k, v in ms.items()}}
        print(key, {k: v for k, v in out[key].items() if k != "rounds_ms"}, flush=True)
    write_results(a.out, {"benchmark": "film_free_probe", "res": res, "drjit_threads": 1, "calls_per_round": 20,
                          "configs": out}, a.note)


if __name__ == "__main__":
    main()
