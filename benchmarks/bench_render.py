"""End-to-end cost, size and accuracy of `svgen render` at the default quality (256^2), and the storage decision.

1. A variants store of one preset per material class (19 classes), ``--tasks`` x ``--chunk`` SVBRDFs in all
   (per_preset variants of each: 320 at the defaults), 256^2, `svgen sample` code.
2. cpu_s_per_view: the default setting (dask, 2 local worker processes, cores // workers = 1 drjit thread
   each; tasks of the default render.chunk, 64 SVBRDFs, as the pipeline runs), end to end per chunk task -- read and decode maps, draw views, transform maps, render, encode,
   compress, write the chunk: the worker process's CPU time (all its threads, zarr's I/O thread included)
   around each task, summed over the tasks after each worker's first (which pays the one-time start: imports,
   scene load, kernel compilation; reported separately). Also: `run_render` in this process (--workers 0,
   2 drjit threads), start included.
3. views_per_s: views / wall time of the whole dask run of the tasks, cluster start excluded.
4. bytes_per_view: the finished store's bytes on disk / views, and per array.
5. Storage decision: bytes and read time per view of (a) aligned maps stored per view (uint16 like the base
   maps, or uint8) vs (b) recomputed by RendersReader.maps from the stored base maps.
6. rel_rmse_vs_reference: the stored image (8-bit sRGB, decoded) against a converged sphere-light reference
   (512 spp stratified), one view per SVBRDF, pooled; and the 8-bit quantisation's share of it. 5 and 6 use one
   SVBRDF per class (spread evenly over the store).

Until 2026-12-03 the tasks were of 1 SVBRDF (``--chunk 1``) on 19 SVBRDFs: each task then paid the shard writes of
every array for 10 views, which the pipeline's tasks of 64 share among 640.

Writes benchmarks/results/render.json. Usage: python3 benchmarks/bench_render.py [--quick].
"""
from __future__ import annotations

import dataclasses
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from materials import registry
from materials.maps import MAP_SLICES, encode_normal, pack_maps
from pipeline.config import RenderConfig, SampleConfig
from pipeline.render.scene import FlashScene
from pipeline.render.stage import run_render
from storage.renders_store import RendersReader
from storage.views import texels_of, transform_planes
from pipeline.sample import run_sample
from svcore.config import build

from harness import RESULTS, parser, timed, write_results

PAPER_CPU_S_PER_VIEW = 11.5  # 16 h on 40 CPUs for ~200,000 views (DESIGN.md)
PAPER_BYTES_PER_VIEW = 425_000  # 85 GB of PNGs for ~200,000 288^2 samples


def dir_bytes(p: Path) -> int:
    return sum(f.stat().st_size for f in p.rglob("*") if f.is_file())


def zstd_bytes(a: np.ndarray) -> int:
    """Compressed size with zstd level 3 (the level of every store array until 2026-12-04; since, of the images:
    ``storage.renders_store.array_specs``), for the estimates of storing aligned maps per view."""
    from numcodecs import Zstd

    return len(Zstd(level=3).encode(np.ascontiguousarray(a)))


def _decode_stored(blob: bytes, shape: tuple) -> np.ndarray:
    """Read maps stored per view (uint16, zstd): decode every channel, normals back to [-1, 1]."""
    from numcodecs import Zstd

    b = np.frombuffer(Zstd().decode(blob), np.uint16).reshape(shape).astype(np.float32) / 65535
    return b[..., MAP_SLICES["normal"]] * 2 - 1


def _timed(task, c: int, threads: int) -> dict:
    """Run one chunk task in a worker and measure the worker process's CPU time around it."""
    t0 = time.perf_counter()
    views, cpu, wall = timed(lambda: task(c, threads))
    return {"pid": os.getpid(), "t0": t0, "views": views, "cpu": cpu, "wall": wall}


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--quick", action="store_true", help="3 SVBRDFs in tasks of 1, no reference (smoke run)")
    ap.add_argument("--chunk", type=int, default=RenderConfig().chunk, help="SVBRDFs per task (the default config's)")
    ap.add_argument("--tasks", type=int, default=5,
                    help="tasks in all; each worker's first pays the start and is left out (5: at least 3 measured)")
    ap.add_argument("--out", default=str(RESULTS / "render.json"))
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="svgen-bench-render-"))
    try:
        by_class: dict[str, str] = {}
        for p in sorted(registry.presets(), key=lambda p: p.name):
            by_class.setdefault(p.name.split("/")[0], p.name)
        presets = tuple(by_class.values())[: 3 if args.quick else None]
        chunk, tasks = (1, 3) if args.quick else (args.chunk, args.tasks)
        per_preset = -(-chunk * tasks // len(presets))
        variants = tmp / "variants.zarr"
        run_sample(variants, build(SampleConfig, "default", presets=presets, per_preset=per_preset, size=256),
                   workers=0)
        # tasks of the pipeline's size, enough of them that each of the 2 workers has tasks after its first (which
        # pays the start); the store layout is the default's (one shard per task), its per-task cost too
        cfg = build(RenderConfig, "default", chunk=chunk)
        n_svbrdf = len(presets) * per_preset
        n_views = n_svbrdf * cfg.views
        # one SVBRDF per class for the storage and accuracy figures, spread evenly over the store
        picked = sorted({int(round(x)) for x in np.linspace(0, n_svbrdf - 1, len(presets))})

        # 2. CPU per view in process; the first chunk alone measures the one-time start
        first = tmp / "first.zarr"
        one = tmp / "one.zarr"
        run_sample(one, build(SampleConfig, "default", presets=presets[:1], per_preset=1, size=256), workers=0)
        cpu_first_chunk = timed(lambda: run_render(one, first, cfg, workers=0)).cpu_s
        out = tmp / "renders.zarr"
        _, cpu, wall = timed(lambda: run_render(variants, out, cfg, workers=0))
        inproc_cpu_s_per_view = cpu / n_views  # scene already loaded and compiled in this process (steady state)

        # 2-3. dask, 2 local workers, CPU time measured inside the workers around each task
        from pipeline.exec.parallel import dask_client, threads_per_worker
        from pipeline.render.stage import chunk_task, render_writer

        out2 = tmp / "renders_dask.zarr"
        writer, n = render_writer(variants, out2, cfg)
        with writer as w, dask_client(2) as client:
            task = chunk_task(w, variants, cfg, n)
            threads = threads_per_worker(client)
            w0 = time.perf_counter()
            n_tasks = -(-n // cfg.chunk)
            futs = client.map(_timed, [task] * n_tasks, list(range(n_tasks)), [threads] * n_tasks, pure=False)
            stats = client.gather(futs)  # dask_client's client is not the default one: gather through it
            wall_dask = time.perf_counter() - w0
            w.finalize()
        by_pid: dict[int, list] = {}
        for st in sorted(stats, key=lambda x: x["t0"]):
            by_pid.setdefault(st["pid"], []).append(st)
        firsts = [v[0] for v in by_pid.values()]
        steady = [x for v in by_pid.values() for x in v[1:]]
        dask_cpu_s_per_view = sum(x["cpu"] for x in steady) / sum(x["views"] for x in steady)
        first_task_extra_cpu = float(np.mean([x["cpu"] - dask_cpu_s_per_view * x["views"] for x in firsts]))
        dask_views_per_s = n_views / wall_dask
        same = all((out / a).exists() for a in ("image",))
        r1, r2 = RendersReader(out), RendersReader(out2)
        identical = bool(np.array_equal(r1.group["image"][:], r2.group["image"][:]))

        # 4. bytes
        total = dir_bytes(out)
        per_array = {a: dir_bytes(out / a) / n_views for a in ("image", "view", "normal", "diffuse", "specular",
                                                               "roughness", "source", "source_seed")}

        # 5. storage alternatives: aligned maps stored per view vs recomputed
        stored16, stored8, t_recompute, t_stored = [], [], [], []
        for i in (s * cfg.views for s in picked):
            m, _, dt = timed(lambda: r1.maps(i))
            t_recompute.append(dt)
            a = pack_maps(dataclasses.replace(m, normal=encode_normal(m.normal)))  # as stored: normals (n+1)/2
            q16 = np.round(np.clip(a, 0, 1) * 65535).astype(np.uint16)
            q8 = np.round(np.clip(a, 0, 1) * 255).astype(np.uint8)
            stored16.append(zstd_bytes(q16))
            stored8.append(zstd_bytes(q8))
            from numcodecs import Zstd

            blob = Zstd(level=3).encode(q16)
            t_stored.append(timed(lambda: _decode_stored(blob, q16.shape)).wall_s)
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
            for s in picked:
                i = s * cfg.views
                v = r1.view_params(i)
                planes = transform_planes(texels_of(r1.base_maps(s)), r1.base_res, v, cfg.res)
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
                                                         "sampler": cfg.sampler, "views": cfg.views,
                                                         "chunk": cfg.chunk},
            "svbrdfs": n_svbrdf, "views": n_views, "measured_views": sum(x["views"] for x in steady),
            "svbrdfs_for_storage_and_accuracy": len(picked),
            "cpu_s_per_view": dask_cpu_s_per_view,
            "cpu_s_per_view_note": f"dask, 2 local workers x 1 drjit thread, tasks of {cfg.chunk} SVBRDFs: worker CPU "
                                   "around each chunk task, first task per worker excluded",
            "views_per_s": dask_views_per_s, "views_per_s_note": "dask, 2 local workers, tasks submitted to a running cluster (start excluded)",
            "cpu_s_one_time_start_per_worker": first_task_extra_cpu, "drjit_threads_per_worker": threads,
            "cpu_s_per_view_in_process": inproc_cpu_s_per_view, "views_per_s_in_process": n_views / wall,
            "cpu_s_one_time_start_in_process": cpu_first_chunk - inproc_cpu_s_per_view * cfg.views,
            "dask_store_identical_to_in_process": identical and same,
            "bytes_per_view": total / n_views, "bytes_per_view_by_array": per_array,
            "paper_cpu_s_per_view": PAPER_CPU_S_PER_VIEW, "speedup_vs_paper": PAPER_CPU_S_PER_VIEW / dask_cpu_s_per_view,
            "paper_bytes_per_view": PAPER_BYTES_PER_VIEW,
            **accuracy, "rel_rmse_vs_reference_note": accuracy and "8-bit sRGB stored image vs converged reference",
            "storage": storage,
            "quick": args.quick,
        }
        write_results(args.out, result, args.note)
        print(json.dumps({k: v for k, v in result.items() if k not in ("storage", "bytes_per_view_by_array")}, indent=1))
        print(json.dumps(storage, indent=1))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
