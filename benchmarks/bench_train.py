"""Training throughput: it/s of a preset on a device and precision (``svtrain fit``'s own step: train.fit.Trainer,
rendering loss included), the loader's samples/s, and how many loader workers a step needs.

    python3 benchmarks/bench_train.py                                   # compact, cpu, fp32 (the README figure)
    python3 benchmarks/bench_train.py --precision bf16
    python3 benchmarks/bench_train.py --config-preset paper --steps 2 --no-compile --loader-store build
    python3 benchmarks/bench_train.py --config-preset paper --device cuda --precision bf16 --steps 50   # on a GPU

Every run adds (or replaces) its row, keyed by (preset, device, precision, batch), in ``rows`` of
``benchmarks/results/train.json``; the compact/cpu/fp32 run also refreshes the top-level figures the README quotes.

Loader sizing (``--loader-store``): samples/s of the DataLoader at the preset's crop (256² for paper) with 1 worker
and with ``--workers``, read from a renders store (``build``: a small one rendered into a temp dir by svgen, so
the figure includes zarr reads and the view transform, not just the in-memory synthetic source). Against it stands
what one step of the preset consumes (batch x it/s): workers needed = consumed / per-worker samples/s.
"""
from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import torch

from train.config import Config, resolve
from train.data import PairDataset, make_loader, open_source, split_by_source
from train.fit import Trainer
from train.net import count_parameters
from train.synthetic import SyntheticSource

from harness import RESULTS, command, machine_info, parser, write_results

NOTE = ("measured on a shared 2-core machine (other jobs running; load averages recorded): rerun on a quiet machine "
        "before quoting")


def bench_steps(cfg, src, train_idx, steps: int) -> dict:
    """it/s of ``Trainer.step`` (host batch -> device copy, autocast forward, float32 loss, backward, Adam)."""
    trainer = Trainer(cfg)
    ds = PairDataset(src, train_idx, cfg.data.crop, 0, train=True)
    b = trainer.batch
    batches = []
    for t in range(2):
        items = [ds[t * b + k] for k in range(b)]
        batches.append((torch.stack([i[0] for i in items]), torch.stack([i[1] for i in items])))
    trainer.model.train()
    sync = torch.cuda.synchronize if trainer.place.device.type == "cuda" else (lambda: None)

    def step(t):
        img, maps = batches[t % len(batches)]
        return trainer.step(img, maps, t)[0]

    t0 = time.perf_counter()
    step(0)  # warm-up (and the one-off compile)
    sync()
    warm = time.perf_counter() - t0
    step(1)
    sync()
    t0, c0 = time.perf_counter(), time.process_time()
    for t in range(steps):
        loss = step(t)
    sync()
    wall = time.perf_counter() - t0
    out = {"it_per_s": steps / wall, "s_per_it": wall / steps, "cpu_s_per_it": (time.process_time() - c0) / steps,
           "warmup_s": round(warm, 1), "parameters": count_parameters(trainer.net), "last_loss": loss}
    if trainer.place.device.type == "cuda":
        out["gpu_peak_gb"] = round(torch.cuda.max_memory_allocated() / 1e9, 2)
        out["gpu"] = torch.cuda.get_device_name()
    return out


def bench_loader(crop: int, batch_size: int, src, train_idx, batches: int, workers: int) -> float:
    """Samples/s the loader delivers with ``workers`` processes (after start-up), crops of ``crop``²."""
    ds = PairDataset(src, train_idx, crop, 0, train=True)
    loader = make_loader(ds, batch_size, 0, batches + 2, workers)
    it = iter(loader)
    next(it)
    next(it)  # workers started
    t0 = time.perf_counter()
    n = 0
    for img, _ in it:
        n += img.shape[0]
    return n / (time.perf_counter() - t0)


def build_store(root: Path, res: int) -> Path:
    """A small renders store (4 SVBRDFs x 5 views at ``res``²) made by svgen in a child process: this process must
    run no drjit kernel before the loader forks its workers (see experiments/train_budget/bench_train_budget.py)."""
    code = (f"from pipeline.config import RenderConfig, SampleConfig\n"
            f"from pipeline.render.stage import run_render\n"
            f"from svcore.config import build\n"
            f"from pipeline.sample import run_sample\n"
            f"run_sample('{root}/v.zarr', build(SampleConfig, 'default', presets=('paint/glossy_red', "
            f"'wood/oak_planks'), per_preset=2, size={res}), workers=0)\n"
            f"run_render('{root}/v.zarr', '{root}/r.zarr', build(RenderConfig, 'default', views=5, res={res}), "
            f"workers=0)\n")
    subprocess.run([sys.executable, "-c", code], check=True, env={**os.environ, "SVGEN_NO_PROGRESS": "1"})
    return root / "r.zarr"


def loader_sizing(preset: str, batch_size: int, store: str, workers: int, batches: int) -> dict:
    """Loader samples/s at the ``preset``'s crop from a renders store, with 1 worker and with ``workers``."""
    with tempfile.TemporaryDirectory(prefix="bench-train-") as tmp:
        res = resolve(preset, None, {}).data.synthetic_size
        path = build_store(Path(tmp), res) if store == "build" else Path(store)
        c = resolve(preset, None, {"data.store": str(path), "optim.batch_size": batch_size})
        src = open_source(c.data)
        idx = list(range(len(src)))  # throughput only: every view
        one = bench_loader(c.data.crop, batch_size, src, idx, batches, 1)
        many = bench_loader(c.data.crop, batch_size, src, idx, batches, workers) if workers > 1 else one
        return {"store": "built: 4 SVBRDFs x 5 views rendered by svgen" if store == "build" else store,
                "store_res": int(src.res) if hasattr(src, "res") else None, "crop": c.data.crop,
                "batch_size": c.optim.batch_size, "samples_per_s_1_worker": round(one, 1),
                f"samples_per_s_{workers}_workers": round(many, 1), "per_worker_samples_per_s": round(one, 1)}


def native_bf16() -> bool | None:
    """Whether this CPU has bf16 instructions (AVX512-BF16 or AMX-BF16 in /proc/cpuinfo; None where that file is
    not there): CPU bf16 autocast is faster than fp32 with them and several times slower without."""
    try:
        flags = Path("/proc/cpuinfo").read_text().split()
    except OSError:
        return None
    return "avx512_bf16" in flags or "amx_bf16" in flags


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.set_defaults(note=NOTE)
    ap.add_argument("--config-preset", default=Config.DEFAULT_PRESET, choices=list(Config.PRESETS),
                    help="svtrain's config preset")
    ap.add_argument("--device", default="cpu", help="auto, cpu, cuda, cuda:N, mps")
    ap.add_argument("--precision", default="fp32", help="fp32, bf16, fp16 (GPU)")
    ap.add_argument("--batch", type=int, default=None, help="batch size (default: the preset's)")
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--no-compile", action="store_true")
    ap.add_argument("--loader-store", default=None,
                    help="renders store for the loader sizing at the preset's crop ('build': render a small one)")
    ap.add_argument("--out", default=str(RESULTS / "train.json"))
    a = ap.parse_args(argv)
    torch.set_num_threads(a.threads)
    ov = {"compute.device": a.device, "compute.precision": a.precision, "optim.compile_loss": not a.no_compile}
    if a.batch:
        ov["optim.batch_size"] = a.batch
    cfg = resolve(a.config_preset, None, ov)
    src = SyntheticSource(32, cfg.data.synthetic_size, 8, seed=0)
    train_idx, _ = split_by_source(src, cfg.data.holdout, 0)
    load0 = os.getloadavg()[0]
    steps = bench_steps(cfg, src, train_idx, a.steps)
    consumption = steps["it_per_s"] * cfg.optim.batch_size
    row = {"preset": cfg.preset, "device": a.device, "precision": a.precision, "batch_size": cfg.optim.batch_size,
           "crop": cfg.data.crop, "threads": a.threads, "compile_loss": not a.no_compile, "steps_timed": a.steps,
           **{k: round(v, 4) if isinstance(v, float) else v for k, v in steps.items()},
           "consumed_samples_per_s": round(consumption, 2),
           "cpu_native_bf16": native_bf16() if a.device == "cpu" else None,
           "load_average_before": round(load0, 2), "load_average_after": round(os.getloadavg()[0], 2),
           "machine": machine_info(), "command": command(), "note": a.note}
    if a.loader_store:
        sizing = loader_sizing(cfg.preset, cfg.optim.batch_size, a.loader_store, a.workers,
                               8 if cfg.data.crop >= 256 else 30)
        sizing["workers_needed_for_this_step"] = round(consumption / sizing["per_worker_samples_per_s"], 2)
        row["loader"] = sizing
    out_path = Path(a.out)
    res = json.loads(out_path.read_text()) if out_path.is_file() else {"benchmark": "bench_train"}
    key = (row["preset"], row["device"], row["precision"], row["batch_size"])
    res["rows"] = [r for r in res.get("rows", []) if (r["preset"], r["device"], r["precision"], r["batch_size"])
                   != key] + [row]
    if key == ("compact", "cpu", "fp32", 8):  # the README's figure: loader against consumption at 128²
        loader = bench_loader(cfg.data.crop, cfg.optim.batch_size, src, train_idx, 60, a.workers)
        res.update({"preset": cfg.preset, "model": cfg.to_dict()["model"], "batch_size": cfg.optim.batch_size,
                    "crop": cfg.data.crop, "threads": a.threads, "compile_loss": not a.no_compile,
                    **{k: row[k] for k in ("it_per_s", "s_per_it", "cpu_s_per_it", "warmup_s", "parameters")},
                    "loader_samples_per_s": round(loader, 1), "loader_workers": a.workers,
                    "consumed_samples_per_s": round(consumption, 1),
                    "loader_vs_consumption": round(loader / consumption, 2),
                    "peak_rss_gb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6, 3),
                    "load_average_before": row["load_average_before"], "load_average_after": row["load_average_after"],
                    "bars": {"it_per_s": 2.0, "loader_vs_consumption": 5.0}})
    # the top-level command and machine are the latest run's (each row keeps its own)
    res.update({"command": row["command"], "machine": row["machine"]})
    for stale in ("cpus", "torch"):  # machine facts from before the harness: now under "machine"
        res.pop(stale, None)
    write_results(out_path, res, a.note)
    print(json.dumps(row, indent=2))


if __name__ == "__main__":
    main()
