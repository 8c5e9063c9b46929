"""End-to-end cost, size and accuracy of `svgen render` at the default quality (256^2), and the storage decision.

1. A variants store of one preset per material class (9 SVBRDFs, 256^2, `svgen sample` code).
2. cpu_s_per_view: the default run (dask, 2 local worker processes, 1 drjit thread each), end to end -- read
   and decode maps, draw views, transform maps, render, encode, compress, write the store: CPU time of all
   processes (this one + reaped children via RUSAGE_CHILDREN). The one-time start (cluster, imports, scene
   load, kernel compilation; several CPU-seconds) is removed by differencing a 1-SVBRDF run and the full run.
   Also reported: in this process (--workers 0, 2 drjit threads), where the machine's other load shows more.
3. views_per_s: the same differencing on wall-clock time (steady state of 2 workers).
4. bytes_per_view: the finished store's bytes on disk / views, and per array.
5. Storage decision: bytes and read time per view of (a) aligned maps stored per view (uint16 like the base
   maps, or uint8) vs (b) recomputed by RendersReader.maps from the stored base maps.
6. rel_rmse_vs_reference: the stored image (8-bit sRGB, decoded) against a converged sphere-light reference
   (512 spp stratified), one view per SVBRDF, pooled; and the 8-bit quantisation's share of it.

Writes benchmarks/results/render.json. Usage: python3 benchmarks/bench_render.py [--quick].
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from materials import registry  # noqa: E402
from pipeline.config import SampleConfig, build  # noqa: E402
from pipeline.render.encoding import decode_srgb8  # noqa: E402
from pipeline.render.scene import FlashScene  # noqa: E402
from pipeline.render.stage import RenderConfig, run_render  # noqa: E402
from pipeline.render.store import RendersReader  # noqa: E402
from pipeline.render.views import planes_of, transform_planes  # noqa: E402
from pipeline.sample import run_sample  # noqa: E402

PAPER_CPU_S_PER_VIEW = 11.5  # 16 h on 40 CPUs for ~200,000 views (DESIGN.md)
PAPER_BYTES_PER_VIEW = 425_000  # 85 GB of PNGs for ~200,000 288^2 samples


def dir_bytes(p: Path) -> int:
    return sum(f.stat().st_size for f in p.rglob("*") if f.is_file())


def zstd_bytes(a: np.ndarray) -> int:
    """Compressed size with the stores' codec (zstd level 5)."""
    from numcodecs import Zstd

    return len(Zstd(level=5).encode(np.ascontiguousarray(a)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="3 SVBRDFs, no reference (smoke run)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "render.json"))
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="svgen-bench-render-"))
    try:
        by_class: dict[str, str] = {}
        for p in sorted(registry.presets(), key=lambda p: p.name):
            by_class.setdefault(p.name.split("/")[0], p.name)
        presets = tuple(by_class.values())[: 3 if args.quick else None]
        variants = tmp / "variants.zarr"
        run_sample(variants, build(SampleConfig, "default", presets=presets, per_preset=1, size=256), workers=0)
        cfg = build(RenderConfig, "default", chunk=1)
        n_views = len(presets) * cfg.views

        # 2. CPU per view in process; the first chunk alone measures the one-time start
        first = tmp / "first.zarr"
        one = tmp / "one.zarr"
        run_sample(one, build(SampleConfig, "default", presets=presets[:1], per_preset=1, size=256), workers=0)
        c0 = time.process_time()
        run_render(one, first, cfg, workers=0)
        cpu_first_chunk = time.process_time() - c0
        out = tmp / "renders.zarr"
        c0, w0 = time.process_time(), time.perf_counter()
        run_render(variants, out, cfg, workers=0)
        cpu = time.process_time() - c0
        wall = time.perf_counter() - w0
        inproc_cpu_s_per_view = cpu / n_views  # scene already loaded and compiled in this process (steady state)

        # 2-3. dask, 2 local workers: a 1-SVBRDF run and the full run; the difference is the steady state
        import resource

        def cpu_all():
            a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
            return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime

        c0, w0 = cpu_all(), time.perf_counter()
        run_render(one, tmp / "one_dask.zarr", cfg, workers=2)
        cpu1, wall1 = cpu_all() - c0, time.perf_counter() - w0
        out2 = tmp / "renders_dask.zarr"
        c0, w0 = cpu_all(), time.perf_counter()
        run_render(variants, out2, cfg, workers=2)
        cpu2, wall_dask = cpu_all() - c0, time.perf_counter() - w0
        dask_cpu_s_per_view = (cpu2 - cpu1) / (n_views - cfg.views)
        dask_views_per_s = (n_views - cfg.views) / max(wall_dask - wall1, 1e-9)
        same = all((out / a).exists() for a in ("image",))
        r1, r2 = RendersReader(out), RendersReader(out2)
        identical = bool(np.array_equal(r1.group["image"][:], r2.group["image"][:]))

        # 4. bytes
        total = dir_bytes(out)
        per_array = {a: dir_bytes(out / a) / n_views for a in ("image", "view", "normal", "diffuse", "specular",
                                                               "roughness", "source", "source_seed")}

        # 5. storage alternatives: aligned maps stored per view vs recomputed
        stored16, stored8, t_recompute, t_stored = [], [], [], []
        for i in range(len(r1)):
            t = time.perf_counter()
            m = r1.maps(i)
            t_recompute.append(time.perf_counter() - t)
            a = np.concatenate([(m.normal + 1) / 2, m.diffuse, m.specular, m.roughness], -1)
            q16 = np.round(np.clip(a, 0, 1) * 65535).astype(np.uint16)
            q8 = np.round(np.clip(a, 0, 1) * 255).astype(np.uint8)
            stored16.append(zstd_bytes(q16))
            stored8.append(zstd_bytes(q8))
            from numcodecs import Zstd

            blob = Zstd(level=5).encode(q16)
            t = time.perf_counter()
            b = np.frombuffer(Zstd().decode(blob), np.uint16).reshape(q16.shape).astype(np.float32) / 65535
            _ = b[..., 0:3] * 2 - 1
            t_stored.append(time.perf_counter() - t)
        storage = {
            "decision": "recompute aligned maps from stored base maps + view transform",
            "recomputed": {"bytes_per_view": total / n_views, "read_s_per_view": float(np.median(t_recompute))},
            "stored_uint16": {"bytes_per_view": total / n_views + float(np.mean(stored16)),
                              "maps_bytes_per_view": float(np.mean(stored16)),
                              "read_s_per_view_decode_only": float(np.median(t_stored))},
            "stored_uint8": {"bytes_per_view": total / n_views + float(np.mean(stored8)),
                             "maps_bytes_per_view": float(np.mean(stored8))},
            "budget_bytes_per_view": 200_000,
        }

        # 6. accuracy against a converged reference
        accuracy = {}
        if not args.quick:
            ref_scene = FlashScene(cfg.res, 64, "sphere", "stratified")
            e2 = r2_ = q2 = 0.0
            per = []
            for s in range(r1.n_svbrdf):
                i = s * cfg.views
                v = r1.view_params(i)
                planes = transform_planes(planes_of(r1.base_maps(s)), r1.base_res, v, cfg.res)
                ref = np.clip(np.mean([ref_scene.render_planes(planes, (v.light_x, v.light_y), 10_000 + k, clip=False)
                                       for k in range(8)], axis=0), 0, 1)
                raw = FlashScene(cfg.res, cfg.spp, cfg.light, cfg.sampler).render_planes(
                    planes, (v.light_x, v.light_y), v.seed)
                img = r1.image(i)
                e2 += float(np.sum((img - ref) ** 2))
                q2 += float(np.sum((img - raw) ** 2))
                r2_ += float(np.sum(ref**2))
                per.append(float(np.sqrt(np.sum((img - ref) ** 2) / np.sum(ref**2))))
            accuracy = {"rel_rmse_vs_reference": float(np.sqrt(e2 / r2_)), "rel_rmse_max_view": max(per),
                        "rel_rmse_of_8bit_quantisation": float(np.sqrt(q2 / r2_)),
                        "reference": "sphere light r=0.02, stratified 8 x 64 spp"}

        result = {
            "benchmark": "render_end_to_end", "config": {"res": cfg.res, "spp": cfg.spp, "light": cfg.light,
                                                         "sampler": cfg.sampler, "views": cfg.views},
            "svbrdfs": len(presets), "views": n_views,
            "cpu_s_per_view": dask_cpu_s_per_view,
            "cpu_s_per_view_note": "dask, 2 local workers x 1 drjit thread, all processes, steady state (start removed)",
            "views_per_s": dask_views_per_s, "views_per_s_note": "dask, 2 local workers, steady state",
            "dask_cold_start_s": wall1 - cfg.views / dask_views_per_s,
            "cpu_s_per_view_in_process": inproc_cpu_s_per_view, "views_per_s_in_process": n_views / wall,
            "cpu_s_one_time_start_in_process": cpu_first_chunk - inproc_cpu_s_per_view * cfg.views,
            "dask_store_identical_to_in_process": identical and same,
            "bytes_per_view": total / n_views, "bytes_per_view_by_array": per_array,
            "paper_cpu_s_per_view": PAPER_CPU_S_PER_VIEW, "speedup_vs_paper": PAPER_CPU_S_PER_VIEW / dask_cpu_s_per_view,
            "paper_bytes_per_view": PAPER_BYTES_PER_VIEW,
            **accuracy, "rel_rmse_vs_reference_note": accuracy and "8-bit sRGB stored image vs converged reference",
            "storage": storage,
            "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "python": platform.python_version()},
            "quick": args.quick,
        }
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(json.dumps(result, indent=1))
        print(json.dumps({k: v for k, v in result.items() if k not in ("storage", "bytes_per_view_by_array")}, indent=1))
        print(json.dumps(storage, indent=1))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
