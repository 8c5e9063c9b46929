"""Eval error against training wall time for several network widths on a real renders store (#4, chart 2 of #5).

For each base width (max width 8x base, 7 levels, 128² crops, batch 8, Adam beta1 0.5) train from the same
seed on the store's training split (held out by preset, as ``svtrain fit``) for a fixed wall-clock budget, and
evaluate the held-out split (a fixed, evenly spaced subset of views, centre crops) at ~6 points along the way.
Every point records training wall seconds, CPU seconds (this process + its loader workers), steps, the
training loss and the held-out RMSEs (re-rendering and per map). Both baselines are evaluated once.

The budget becomes a step count before each run (``calibrate_steps``: it/s of a short throwaway run of the same
width), because a learning-rate schedule needs ``optim.iterations`` up front. The run is then ``svtrain fit``'s:
``train.fit.Trainer`` (seeded init, Adam, loss generator, the step with its schedule and gradient clipping, the
loader whose batches of step t are a pure function of (seed, t)), iterated exactly as ``svtrain fit`` iterates it,
so the final point is the model ``svtrain fit`` gives with ``optim.iterations`` = that step count. Evaluation time
is not counted as training time. The loss compile (torch.compile, one-off, cached on disk) runs before the clock
starts; whether it is used at all is decided by a short eager-vs-compiled timing of the loss at the start.

Outputs (in ``--out``, default this experiment's ``results/``): ``train_budget.json`` and ``.csv``,
``eval_budget.md`` (the ``--table-width`` model, by default the compact one, after its budget, model vs baselines)
and ``docs/img/chart_training.png`` (``benchmarks/charts/training.py``).

    S=experiments/train_budget
    python3 $S/bench_train_budget.py --table-width 8          # widths 8/16/32 x 10 min (train_budget.json)
    python3 $S/bench_train_budget.py --widths 8 --budget-s 1800 --out $S/results/budget_30min --png ''
    python3 $S/bench_train_budget.py --widths 8 --steps 2707 --set optim.map_l1=0.1 --out /tmp/p --png ''  # A/B

On a shared machine, calibrate on a quiet moment and train later: ``--calibrate-only F`` writes each width's
quiet it/s and step count to F (a few minutes); ``--steps-from F`` then trains exactly those steps whatever the
load, and every point also records ``budget_s`` (steps / quiet it/s, the training time the same steps take on
the quiet machine), which the chart uses as its x axis. Training is deterministic, so the errors are the ones a
quiet run would give; only the recorded wall times are stretched by the load.

    python3 $S/bench_train_budget.py --calibrate-only $S/results/train_budget_calibration.json
    python3 $S/bench_train_budget.py --steps-from $S/results/train_budget_calibration.json --table-width 8
"""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import psutil
import torch

from train.config import parse_overrides, preset, resolve
from train.data import PairDataset, open_source, packed_maps, split_by_source
from train.evaluate import COLUMNS, evaluate, markdown, metrics, train_means
from train.fit import Trainer, lr_at
from train.loss import make_loss
from train.net import count_parameters

# harness.py stays in benchmarks/; this finished experiment imports it from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import IMG, ROOT, parser, write_csv, write_results  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"

BASELINES = ("input_as_diffuse", "dataset_mean")
#: eval points as fractions of the budget (plus step 0).
FRACTIONS = (1 / 16, 1 / 8, 1 / 4, 1 / 2, 3 / 4, 1.0)


class CachedSource:
    """The eval views read once into memory (centre crops), so that repeated evaluations cost no store reads.

    ``evaluate`` centre-crops ``crop`` out of what ``image``/``packed`` return; a crop-sized array is its own
    centre crop, so the result is the same as evaluating the store directly.
    """

    def __init__(self, src, indices, crop: int):
        self.images, self.maps = {}, {}
        self.views = getattr(src, "views", None)  # views per SVBRDF: evaluate's cluster bootstrap groups by SVBRDF
        if src is None:
            return
        for i in indices:
            img = np.asarray(src.image(int(i)), np.float32)
            mp = packed_maps(src, int(i))
            y0, x0 = (img.shape[0] - crop) // 2, (img.shape[1] - crop) // 2
            self.images[int(i)] = np.ascontiguousarray(img[y0:y0 + crop, x0:x0 + crop])
            self.maps[int(i)] = np.ascontiguousarray(mp[y0:y0 + crop, x0:x0 + crop])
        self.n = len(src)

    def __len__(self) -> int:
        return self.n

    def image(self, i: int) -> np.ndarray:
        return self.images[int(i)]

    def packed(self, i: int) -> np.ndarray:
        return self.maps[int(i)]


def _prepare(data_cfg, eval_idx, train_idx, crop: int, seed: int) -> tuple:
    """In a spawned process: read the eval views and the training means (both need drjit's map transform)."""
    torch.set_num_threads(1)
    src = open_source(data_cfg)
    cache = CachedSource(src, eval_idx, crop)
    return cache.images, cache.maps, len(src), cache.views, train_means(src, train_idx, crop, seed).numpy()


def prepare_eval(data_cfg, eval_idx, train_idx, crop: int, seed: int) -> tuple["CachedSource", torch.Tensor]:
    """The eval cache and the baseline means, read in a child process.

    This process must not run a drjit kernel before the loader forks its workers: a forked child inherits drjit's
    thread pool without its threads, and the workers' ``drjit.set_thread_count(1)`` (train.data._one_thread), or any
    kernel they launch, then waits forever (seen here: a hang at the first batch). ``svtrain fit`` is safe for the
    same reason: its process reads no maps before forking.
    """
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as ex:
        images, maps, n, views, means = ex.submit(_prepare, data_cfg, eval_idx, train_idx, crop, seed).result()
    cache = CachedSource(None, [], crop)
    cache.images, cache.maps, cache.n, cache.views = images, maps, n, views
    return cache, torch.from_numpy(means)


def cpu_seconds(proc: psutil.Process) -> float:
    """user + system CPU seconds of this process and its live children (loader workers)."""
    t = proc.cpu_times()
    total = t.user + t.system
    for c in proc.children(recursive=True):
        try:
            ct = c.cpu_times()
            total += ct.user + ct.system
        except psutil.Error:
            pass
    return total


def make_cfg(a, base: int):
    return resolve("compact", None, {**parse_overrides(a.set),
        "data.store": a.store, "data.crop": a.crop, "data.workers": a.workers,
        "model.base_width": base, "model.max_width": 8 * base, "model.levels": a.levels,
        "optim.lr": a.lr, "optim.beta1": 0.5, "optim.batch_size": a.batch, "optim.seed": a.seed,
        "optim.threads": a.threads, "optim.compile_loss": a.compile == "on", "optim.grad_clip": a.grad_clip,
        "optim.schedule": a.schedule})


def compile_probe(batch, crop: int, steps: int = 6) -> dict:
    """s per loss forward+backward (fixed random maps), eager vs torch.compile (compile time reported apart)."""
    g = torch.Generator().manual_seed(0)
    target = torch.rand(batch, 10, crop, crop, generator=g)
    pred0 = torch.rand(batch, 10, crop, crop, generator=g)
    out = {}
    for name, comp in (("eager", False), ("compiled", True)):
        fn = make_loss(comp)
        t0 = time.perf_counter()
        p = pred0.clone().requires_grad_()
        fn(p, target, torch.Generator().manual_seed(1)).backward()
        first = time.perf_counter() - t0
        t0 = time.perf_counter()
        for k in range(steps):
            p = pred0.clone().requires_grad_()
            fn(p, target, torch.Generator().manual_seed(2 + k)).backward()
        out[name] = {"s_per_loss_step": (time.perf_counter() - t0) / steps, "first_call_s": round(first, 1)}
    out["speedup"] = out["eager"]["s_per_loss_step"] / out["compiled"]["s_per_loss_step"]
    return out


def eval_batches_of(eval_src, eval_idx, crop: int, seed: int, batch: int = 8) -> list:
    """The eval set as (image, maps) batches, built once (the same centre crops ``evaluate`` takes)."""
    ds = PairDataset(eval_src, eval_idx, crop, seed, train=False)
    out = []
    for lo in range(0, len(ds), batch):
        items = [ds[k] for k in range(lo, min(lo + batch, len(ds)))]
        out.append((torch.stack([x[0] for x in items]), torch.stack([x[1] for x in items])))
    return out


@torch.no_grad()
def eval_model(model, batches) -> dict:
    """The model's mean RMSEs per column: ``evaluate``'s numbers without re-evaluating the fixed baselines
    (``train.evaluate.metrics`` per batch, means over samples; checked against ``evaluate`` at the end)."""
    model.eval()
    acc = {c: [] for c in COLUMNS}
    for img, gt in batches:
        for c, v in metrics(model(img), gt).items():
            acc[c].extend(v.tolist())
    return {c: float(np.mean(v)) for c, v in acc.items()}


def calibrate_steps(cfg, ds, budget_s: float, probe_steps: int = 60, skip: int = 20) -> tuple[int, float]:
    """Steps that fill ``budget_s`` of training wall time: it/s of ``probe_steps`` steps (the first ``skip``
    untimed: loader workers starting, first batches and the loss compile are slower) of a throwaway model of the
    same width on the same loader. A learning-rate schedule needs the step
    count before the run starts, so the budget becomes ``optim.iterations``, as ``svtrain fit`` would be given."""
    t0 = None
    for done, _, _ in Trainer(cfg).run(ds, 0, probe_steps):  # svtrain fit's loop
        if done == skip:
            t0 = time.perf_counter()
    rate = (probe_steps - skip) / (time.perf_counter() - t0)
    return max(1, int(round(budget_s * rate))), rate


def run_width(a, base: int, src, train_idx, eval_src, eval_idx, eval_batches, means) -> dict:
    cfg = make_cfg(a, base)
    ds = PairDataset(src, train_idx, cfg.data.crop, cfg.optim.seed, train=True, flips=cfg.data.augment)
    # one-off setup outside the clock: the loss compile (inside the first probe step) and the step count
    t0 = time.perf_counter()
    quiet = a.calibration.get(str(base)) if a.calibration else None
    if quiet:
        iterations, probe_rate = int(quiet["steps"]), float(quiet["it_per_s"])
    else:
        iterations, probe_rate = (a.steps, None) if a.steps else calibrate_steps(cfg, ds, a.budget_s)
    setup_s = time.perf_counter() - t0
    cfg.optim.iterations = iterations
    o = cfg.optim
    trainer = Trainer(cfg)  # svtrain fit's loop: build, loader, step (schedule, clipping), device, precision
    model = trainer.net

    proc = psutil.Process()
    points, losses, norms = [], [], []
    marks = sorted({max(1, int(round(f * iterations))) for f in FRACTIONS})
    step, eval_wall, eval_cpu = 0, 0.0, 0.0

    def do_eval(train_wall: float, cpu0: float) -> None:
        nonlocal eval_wall, eval_cpu
        e0, c0 = time.perf_counter(), time.process_time()
        m = eval_model(model, eval_batches)
        model.train()
        dt, dc = time.perf_counter() - e0, time.process_time() - c0
        eval_wall += dt
        eval_cpu += dc
        pt = {"wall_s": round(train_wall, 1),
              "budget_s": round(step / probe_rate, 1) if probe_rate else round(train_wall, 1),
              "cpu_s": round(cpu_seconds(proc) - cpu0 - eval_cpu, 1), "steps": step,
              "lr": lr_at(o, max(step - 1, 0)),
              "train_loss": float(np.mean(losses[-50:])) if losses else None,
              "grad_norm": float(np.median(norms[-50:])) if norms else None,
              **{c: m[c] for c in COLUMNS}, "mean_rmse": float(np.mean([m[c] for c in COLUMNS])),
              "eval_s": round(dt, 1), "load1": round(os.getloadavg()[0], 2)}
        points.append(pt)
        print(json.dumps({"base_width": base, **{k: (round(v, 4) if isinstance(v, float) else v)
                                                 for k, v in pt.items()}}), flush=True)

    model.train()
    t_start, cpu_start = time.perf_counter(), cpu_seconds(proc)
    do_eval(0.0, cpu_start)
    load0 = os.getloadavg()[0]
    # timeout: a stuck loader worker fails the run instead of hanging it
    for step, loss, norm in trainer.run(ds, 0, iterations, timeout=300):
        losses.append(loss)
        norms.append(norm)
        if step == marks[0]:
            marks.pop(0)
            do_eval(time.perf_counter() - t_start - eval_wall, cpu_start)  # evaluations are not training time
    final = points[-1]
    ref = None
    if base == a.table_width:  # the authoritative table (svtrain eval's code), for the width under study
        ref = evaluate(model, eval_src, eval_idx, cfg.data.crop, means, 8, a.seed if a.split_seed is None else a.split_seed)
        ref["matches_points"] = all(abs(ref["model"][c] - final[c]) < 1e-5 for c in COLUMNS)
    return {"base_width": base, "max_width": 8 * base, "steps_from": "quiet calibration" if quiet else
            ("--steps" if a.steps else "calibrated at start"), "levels": cfg.model.levels,
            "parameters": count_parameters(model), "setup_s": round(setup_s, 1), "probe_it_per_s": probe_rate and round(probe_rate, 3),
            "steps": step, "it_per_s": round(step / final["wall_s"], 3),
            "cpu_s_per_step": round(final["cpu_s"] / max(step, 1), 3), "load1_start": round(load0, 2),
            "points": points, "final": {c: final[c] for c in (*COLUMNS, "mean_rmse")}, "evaluate": ref,
            "loss_curve": [float(np.mean(losses[k:k + 25])) for k in range(0, len(losses), 25)],
            "grad_norm_quantiles": {q: float(np.quantile(norms, q / 100)) for q in (50, 90, 99)} if norms else None}


def choose(rows: list[dict], key: str, tol: float) -> int:
    """The smallest width whose final ``key`` error is within ``tol`` of the next larger width's."""
    rows = sorted(rows, key=lambda r: r["base_width"])
    for small, large in zip(rows, rows[1:]):
        if small["final"][key] <= large["final"][key] * (1 + tol):
            return small["base_width"]
    return rows[-1]["base_width"]


def csv_rows(rows: list[dict], baselines: dict) -> list[dict]:
    """The CSV beside train_budget.json: one row per eval point of each width, then one per baseline."""
    out = []
    for r in rows:
        for p in r["points"]:
            out.append({"series": f"width_{r['base_width']}", "base_width": r["base_width"],
                        "parameters": r["parameters"], "wall_s": p["wall_s"], "cpu_s": p["cpu_s"], "steps": p["steps"],
                        "train_loss": "" if p["train_loss"] is None else f"{p['train_loss']:.5f}",
                        **{c: f"{p[c]:.5f}" for c in COLUMNS}, "mean_rmse": f"{p['mean_rmse']:.5f}"})
    for name, m in baselines.items():
        out.append({"series": name, "base_width": "", "parameters": "", "wall_s": "", "cpu_s": "", "steps": "",
                    "train_loss": "", **{c: f"{m[c]:.5f}" for c in COLUMNS},
                    "mean_rmse": f"{np.mean([m[c] for c in COLUMNS]):.5f}"})
    return out


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--store", default=str(ROOT / "data" / "renders.zarr"))
    ap.add_argument("--widths", type=int, nargs="+", default=[8, 16, 32])
    ap.add_argument("--budget-s", type=float, default=600.0, help="training wall seconds per width")
    ap.add_argument("--steps", type=int, default=0,
                    help="train this many steps instead of the budget's calibrated count (exact A/B comparisons)")
    ap.add_argument("--lr", type=float, default=preset("compact").optim.lr)
    ap.add_argument("--grad-clip", type=float, default=preset("compact").optim.grad_clip,
                    help="optim.grad_clip (0 = off)")
    ap.add_argument("--schedule", choices=("constant", "cosine"), default=preset("compact").optim.schedule)
    ap.add_argument("--table-width", type=int, default=preset("compact").model.base_width,
                    help="the width whose end-of-budget eval table is written (eval_budget.md)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="any other config override, as svtrain fit --set (repeatable)")
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--crop", type=int, default=128)
    ap.add_argument("--levels", type=int, default=7)
    ap.add_argument("--threads", type=int, default=2, help="torch intra-op threads")
    ap.add_argument("--workers", type=int, default=2, help="DataLoader workers (as svtrain fit)")
    ap.add_argument("--compile", choices=("auto", "on", "off"), default="auto",
                    help="torch.compile the loss (auto: when the probe shows it is faster)")
    ap.add_argument("--eval-views", type=int, default=200, help="held-out views evaluated (evenly spaced subset)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--split-seed", type=int, default=None,
                    help="seed of the held-out split and the eval set (default: --seed, as svtrain fit); fix it to "
                         "compare training seeds on one split")
    ap.add_argument("--tol", type=float, default=0.05, help="'within a few %%' of the width rule")
    ap.add_argument("--out", default=str(RESULTS), help="output folder")
    ap.add_argument("--png", default=str(IMG / "chart_training.png"), help="chart ('' = none)")
    ap.add_argument("--calibrate-only", default="", metavar="JSON",
                    help="measure each width's it/s and budget step count, write them to JSON and stop")
    ap.add_argument("--steps-from", default="", metavar="JSON",
                    help="train each width for the steps a --calibrate-only run recorded (quiet calibration)")
    a = ap.parse_args(argv)
    torch.set_num_threads(a.threads)
    a.calibration = {}
    if a.steps_from:
        cal = json.loads(Path(a.steps_from).read_text())
        a.calibration = cal["widths"]
        a.budget_s = float(cal["budget_wall_s"])
    t_all = time.time()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)

    probe = compile_probe(a.batch, a.crop)
    if a.compile == "auto":
        a.compile = "on" if probe["speedup"] > 1.1 else "off"
    print(json.dumps({"compile_probe": probe, "compile": a.compile}), flush=True)

    cfg0 = make_cfg(a, a.widths[0])
    split_seed = a.seed if a.split_seed is None else a.split_seed
    src = open_source(cfg0.data)
    if a.calibrate_only:
        train_idx, _ = split_by_source(src, cfg0.data.holdout, split_seed)
        cal = {}
        for w in sorted(a.widths):
            cfg = make_cfg(a, w)
            ds = PairDataset(src, train_idx, cfg.data.crop, cfg.optim.seed, train=True, flips=cfg.data.augment)
            load = os.getloadavg()[0]
            steps, rate = calibrate_steps(cfg, ds, a.budget_s)
            cal[str(w)] = {"steps": steps, "it_per_s": round(rate, 4), "load1_before": round(load, 2)}
            print(json.dumps({"base_width": w, **cal[str(w)]}), flush=True)
        write_results(Path(a.calibrate_only), {
            "benchmark": "bench_train_budget --calibrate-only", "budget_wall_s": a.budget_s, "compile_loss": a.compile,
            "widths": cal, "command": "python3 experiments/train_budget/bench_train_budget.py " + " ".join(argv or sys.argv[1:])},
            a.note)
        return
    train_idx, test_idx = split_by_source(src, cfg0.data.holdout, split_seed)
    n_eval = min(a.eval_views, len(test_idx))
    eval_idx = test_idx[np.unique(np.linspace(0, len(test_idx) - 1, n_eval).round().astype(np.int64))]
    t0 = time.perf_counter()
    eval_src, means = prepare_eval(cfg0.data, eval_idx, train_idx, a.crop, split_seed)
    base = evaluate(None, eval_src, eval_idx, a.crop, means, 8, split_seed)
    baselines = {b: base[b] for b in BASELINES}
    print(json.dumps({"baselines": baselines, "eval_views": int(len(eval_idx)),
                      "prep_s": round(time.perf_counter() - t0, 1)}), flush=True)

    eval_batches = eval_batches_of(eval_src, eval_idx, a.crop, split_seed)
    rows = [run_width(a, w, src, train_idx, eval_src, eval_idx, eval_batches, means) for w in sorted(a.widths)]

    default = a.table_width
    chosen = {k: choose(rows, k, a.tol) for k in ("rerender", "mean_rmse")} if len(rows) > 1 else {}
    by_w = {r["base_width"]: r for r in rows}
    eval_budget = None
    if default in by_w:
        ref = by_w[default]["evaluate"]
        m = ref["model"]
        eval_budget = {"model": {c: m[c] for c in COLUMNS}, **{b: ref[b] for b in BASELINES}, "samples": int(len(eval_idx)),
                       "base_width": default, "steps": by_w[default]["steps"],
                       "wall_s": by_w[default]["points"][-1]["wall_s"],
                       "beats_baselines": {c: all(m[c] < ref[b][c] for b in BASELINES) for c in COLUMNS},
                       "paired": ref["paired"],
                       "beats_beyond_noise": {c: all(ref["paired"][b][c]["ci95"][0] > 0 for b in BASELINES)
                                              for c in COLUMNS}}
        wall = eval_budget["wall_s"]
        md = markdown({**eval_budget, "suite": f"heldout (width {default}, {wall:.0f} s)"})
        (out / "eval_budget.md").write_text(
            f"# Base width {default} after {wall:.0f} s of training on 2 cores "
            f"({by_w[default]['steps']} steps, lr {a.lr:g} {a.schedule}, grad clip {a.grad_clip:g})\n\n{md}\n"
            f"beats every baseline on: {', '.join(c for c, v in eval_budget['beats_baselines'].items() if v) or 'none'}"
            f"; not on: {', '.join(c for c, v in eval_budget['beats_baselines'].items() if not v) or 'none'}\n"
            f"with the 95 % interval of the gain above 0 against both baselines on: "
            f"{', '.join(c for c, v in eval_budget['beats_beyond_noise'].items() if v) or 'none'}\n")
    res = {"benchmark": "bench_train_budget", "command": "python3 experiments/train_budget/bench_train_budget.py "
           + " ".join(argv if argv is not None else sys.argv[1:]),
           "store": a.store, "overrides": a.set, "budget_wall_s": a.budget_s, "lr": a.lr, "schedule": a.schedule,
           "grad_clip": a.grad_clip, "beta1": 0.5, "batch_size": a.batch,
           "crop": a.crop, "levels": a.levels, "max_width": "8 x base", "threads": a.threads,
           "loader_workers": a.workers, "compile_loss": a.compile == "on", "compile_probe": probe, "seed": a.seed, "split_seed": split_seed,
           "split": {"train_views": int(len(train_idx)), "heldout_views": int(len(test_idx)),
                     "eval_views": int(len(eval_idx)), "by": "preset (data.holdout of the compact preset)"},
           "optim": cfg0.to_dict()["optim"], "baselines": baselines, "widths": rows, "compact_default": default,
           "eval_budget": eval_budget,
           "tolerance": a.tol, "chosen_base_width": chosen,
           "rule": "smallest width whose eval error at the end of the budget is within tolerance of the next "
                   "larger width's (rerender RMSE; mean of the five columns alongside)",
           "total_wall_s": round(time.time() - t_all, 1)}
    write_results(out / "train_budget.json", res, a.note)
    write_csv(out / "train_budget.csv", csv_rows(rows, baselines))
    if a.png:
        from charts.training import plot

        plot(out / "train_budget.json", a.png)
    print(f"chosen base width: {chosen}; wrote {out / 'train_budget.json'}", flush=True)


if __name__ == "__main__":
    main()
