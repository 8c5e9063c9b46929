"""How a 256^2 view's render call divides into setting the view, tracing and the kernel (#42): drjit's kernel history.

One thread, the stage's path (``FlashScene(in_kernel=True)``), a 256^2 base map of the registry's first preset.
Per view, 30 views each of zoom 0.85 (magnifying, 1 subsample) and 1.25 (minifying, 2 x 2), the first two left
out. It times setting the view and light (``set``), tracing the film-free render and its encoding (``trace``) and
evaluating them (``eval``). From the kernel history it takes the kernel's execution and code generation. Medians in
ms.

    PYTHONPATH=. python3 experiments/direct_calls/probe_trace.py   # -> results/probe_trace.json
"""
from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
RES = 256


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--out", default=str(RESULTS / "probe_trace.json"))
    a = ap.parse_args(argv)
    from svcore.mi_env import dr, mi

    dr.set_thread_count(1)
    import materials
    from pipeline.render.scene import FlashScene
    from storage.views import ViewParams, texels_of

    texels = texels_of(materials.presets()[0].generate(None, RES, 0))
    scene = FlashScene(RES, 1, "point", "centre", in_kernel=True)
    enc = scene._srgb8_encoder()
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    out = {}
    for kind, zoom in (("magnifying", 0.85), ("minifying", 1.25)):
        t = {"set": [], "trace": [], "eval": [], "kernel_execution": [], "codegen": []}
        for k in range(30):
            v = ViewParams(light_x=0.2, light_y=0.1, zoom=zoom, rotation=0.3 * k, seed=k)
            t0 = time.perf_counter()
            scene._plane_bsdf.set_view(texels, v, RES)
            scene.set_light(v.light_x, v.light_y)
            scene.params.update()
            t1 = time.perf_counter()
            rgb = scene._film_free_rgb(v.seed)
            codes = [mi.UInt8(enc._codes(rgb[c])) for c in range(3)]
            t2 = time.perf_counter()
            dr.kernel_history()  # clear
            dr.eval(*codes)
            hist = [h for h in dr.kernel_history() if h["type"] == dr.KernelType.JIT]
            t3 = time.perf_counter()
            if k >= 2:
                t["set"].append(1e3 * (t1 - t0))
                t["trace"].append(1e3 * (t2 - t1))
                t["eval"].append(1e3 * (t3 - t2))
                t["kernel_execution"].append(sum(h["execution_time"] for h in hist))  # ms
                t["codegen"].append(sum(h.get("codegen_time", 0.0) for h in hist))
        out[kind] = {name: statistics.median(x) for name, x in t.items()}
        out[kind]["kernels"] = len(hist)
    write_results(a.out, {"experiment": "direct_calls.probe_trace", "res": RES, "drjit_threads": 1,
                          "ms_median": out}, a.note)
    print(out)


if __name__ == "__main__":
    main()
