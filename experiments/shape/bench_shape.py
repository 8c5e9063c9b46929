"""Which factor makes the compact network learn shape? Short probes at equal step counts (#22).

Every arm trains the compact preset (128² crops) for the same number of steps on the training split of a small
renders store and measures its normals against the flat map on the store's held-out split (and on a subset of its
training views: can it even fit what it sees?). The figure of merit is the normal RMSE relative to the flat map's
on the same views (``rel``; 1 = flat, 0.75 = the issue's aim of 25 % below flat), with a 95 % bootstrap interval over
whole SVBRDFs and training seeds (``ablation_effects``'s scheme). Each factor's effect is ``rel`` of its arm minus
``rel`` of the baseline arm (negative: the change helps); arms on the baseline's store are compared on the same
views (paired resampling of SVBRDFs), arms on another store on their own held-out views (independent resampling).

Arms (``ARMS``): the baseline is the compact default on the default library; then one factor at a time:

- data: an extra band of relief (``svgen sample --set relief=S --set relief_cycles=C``) at coarse, mid or fine
  scales, and its strength;
- network: full-resolution convolutions, a separate normal head, slope parameterisation, twice the width;
- loss: the normal term as slopes or cosine, its weight;
- steps: the baseline at 2x and 4x the probe's steps.

Round 2 (the ``now_*`` arms and stores) measures the factors round 1 left out on today's library and compact default
(width 16): the per-view zoom range (stores re-rendered from ``now``'s variants and blends with ``render.zoom``),
256² training crops and 4x the steps. Each is paired with ``now_base`` on the same held-out views of store ``now``,
evaluated whole (``ROUND2``): ``--build DIR --only now now_z1 now_zw``, then ``--arms now_base ... --steps 600``.

The stores are built once by ``--build DIR`` (the commands are recorded in shape.json), then

    S=experiments/shape/bench_shape.py
    python3 $S --build /tmp/shape                       # the stores (~4 min each, loaded)
    python3 $S --stores /tmp/shape --steps 600          # the arms -> experiments/shape/results/shape.json
    python3 $S --stores /tmp/shape --arms base relief_mid --seeds 0 1   # some arms, more seeds
    python3 $S --chart --merge /tmp/b.json /tmp/c.json   # grids run in parallel, into one file

Results accumulate: an arm (name, seed, steps) already in the output file is not trained again, so a long grid
can be run piecewise. ``--chart`` redraws docs/img/chart_shape.png from the file alone.
"""
from __future__ import annotations

import hashlib
import json
import multiprocessing
import subprocess
import sys
import textwrap
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import IMG, parser, timed, write_results  # noqa: E402

#: this experiment's frozen results (experiments/shape/results/)
RESULTS = Path(__file__).resolve().parent / "results"

#: the stores: name -> (relief RMS slope, relief band centre in cycles per map); relief 0 = the default library.
STORES = {"base": (0.0, 8.0), "c4": (0.15, 4.0), "c12": (0.15, 12.0), "c40": (0.15, 40.0), "c12s": (0.3, 12.0),
          # the base variants with decorrelated blends: a different procedural mask per map, so that a blend's
          # relief and its albedo pattern come from different materials (real materials' normals correlate with
          # their albedo far less than procedural ones:
          # experiments/normal_supervision/results/normals_probe_bundled.json)
          "dmask": (0.0, 8.0, ("--set", "mode=mask", "--set", "mask_per_map=true")),
          # round 2 (2026-11-26): today's default library, and the same variants and blends rendered with another
          # per-view zoom range (render.zoom; the default is log-uniform on [0.7, 1.4])
          "now": (0.0, 8.0),
          "now_z1": (0.0, 8.0, (), ("now", ("--set", "zoom=[1, 1]"))),
          "now_zw": (0.0, 8.0, (), ("now", ("--set", "zoom=[0.5, 2]")))}
#: store building: variants per preset, blends, views per SVBRDF (render resolution 256, the default).
PER_PRESET, BLENDS, VIEWS = 4, 200, 4
#: the compact preset at base width 16 (the grid's choice, today's default), pinned like PROBE_BASE below
WIDTH16 = {"model.base_width": 16, "model.max_width": 128}
#: arms: name -> (factor, store, config overrides, step multiplier, what it tries).
ARMS = {
    "base": ("baseline", "base", {}, 1, "compact default on the default library"),
    "relief_coarse": ("data", "c4", {}, 1, "+ relief at 4 cycles/map (period 64 px), RMS slope 0.15"),
    "relief_mid": ("data", "c12", {}, 1, "+ relief at 12 cycles/map (period 21 px), RMS slope 0.15"),
    "relief_fine": ("data", "c40", {}, 1, "+ relief at 40 cycles/map (period 6 px), RMS slope 0.15"),
    "relief_mid_strong": ("data", "c12s", {}, 1, "+ relief at 12 cycles/map, RMS slope 0.3"),
    "fullres": ("network", "base", {"model.fullres_convs": 2}, 1, "2 full-resolution conv layers"),
    "normal_head": ("network", "base", {"model.normal_head": True}, 1, "separate normal head"),
    "slope_param": ("network", "base", {"model.normal_param": "slope"}, 1, "normals output as slopes"),
    "width16": ("network", "base", WIDTH16, 1, "base width 16"),
    "loss_slope": ("loss", "base", {"optim.normal_loss": "slope"}, 1, "normal term on slopes"),
    "loss_cosine": ("loss", "base", {"optim.normal_loss": "cosine", "optim.normal_l2": 50.0}, 1,
                    "normal term 1 - cosine (weight 50: the same gradient scale as l2 at 100)"),
    "normal_w300": ("loss", "base", {"optim.normal_l2": 300.0}, 1, "normal term weight 300"),
    "steps_x2": ("steps", "base", {}, 2, "2x the steps"),
    "steps_x4": ("steps", "base", {}, 4, "4x the steps"),
    "blend_decorrelated": ("data", "dmask", {}, 1, "blends with a different mask per map (relief and albedo "
                           "from different materials)"),
    "combo": ("combined", "c12s", WIDTH16, 1,
              "relief at 12 cycles/map, RMS slope 0.3 + base width 16 (the two largest single effects)"),
    "combo_w8": ("combined", "c12s", {"optim.normal_l2": 300.0}, 1,
                 "relief at 12 cycles/map, RMS slope 0.3 + normal term weight 300 (width 8)"),
    # round 2: the factors of #22's list round 1 left out, on today's library and today's compact default (width
    # 16); every arm is evaluated on the same held-out views of store "now", whole (256²), against now_base
    "now_base": ("baseline", "now", WIDTH16, 1,
                 "round 2 baseline: today's compact default (width 16) on today's library"),
    "now_crop256": ("network", "now", {**WIDTH16, "data.crop": 256}, 1,
                    "256² training crops (the paper's) instead of 128², equal steps (4x the pixels per step)"),
    "now_zoom_fixed": ("data", "now_z1", WIDTH16, 1,
                       "every training view at zoom 1 (no zoom augmentation; default log-uniform 0.7-1.4)"),
    "now_zoom_wide": ("data", "now_zw", WIDTH16, 1,
                      "training views at zoom log-uniform in [0.5, 2] (default [0.7, 1.4])"),
    "now_steps_x4": ("steps", "now", WIDTH16, 4, "4x the steps"),
}
#: round 2's arms: their baseline arm, and the store whose held-out views (whole, at this crop) they are evaluated on
ROUND2 = {"prefix": "now_", "baseline": "now_base", "eval_store": "now", "eval_crop": 256}


def round2(arm: str) -> bool:
    return arm.startswith(ROUND2["prefix"])


def baseline_of(arm: str) -> str:
    return ROUND2["baseline"] if round2(arm) else "base"


def eval_store_of(arm: str) -> str:
    """The store whose held-out views measure ``arm`` (round 1: its own; round 2: the common one)."""
    return ROUND2["eval_store"] if round2(arm) else ARMS[arm][1]


def eval_crop_of(arm: str) -> int | None:
    """The centre crop ``arm`` is evaluated at (None: its training crop)."""
    return ROUND2["eval_crop"] if round2(arm) else None


def with_parents(names) -> list[str]:
    """Stores to build for ``names``, each after the store whose variants and blends it re-renders."""
    out = []
    for n in names:
        parent = STORES[n][3][0] if len(STORES[n]) > 3 else None
        out += [x for x in (parent, n) if x and x not in out]
    return out
#: the probes' baseline network, pinned (the compact preset's widths when the grid was run), so that a later change
#: of the compact default (the grid chose base width 16) does not change what the baseline arm means
PROBE_BASE = {"model.base_width": 8, "model.max_width": 64}
#: evaluated views: at most this many held-out views (evenly spaced) and training views.
EVAL_VIEWS, TRAIN_VIEWS = 96, 48


def store_path(root: Path, name: str) -> Path:
    return root / f"{name}_r.zarr"


def build_commands(root: Path, name: str) -> list[list[str]]:
    """The svgen commands that make store ``name`` under ``root`` (variants, blends, renders)."""
    relief, cycles, *more = STORES[name]
    blend_args = list(more[0]) if more else []
    v, b, r = (str(root / f"{name}_{k}.zarr") for k in "vbr")
    if len(more) > 1:  # another rendering of a store's variants and blends
        of, render_args = more[1]
        return [["svgen", "render", str(root / f"{of}_v.zarr"), str(root / f"{of}_b.zarr"), r, "--views", str(VIEWS),
                 *render_args]]
    extra = ["--set", f"relief={relief}", "--set", f"relief_cycles={cycles}"] if relief else []
    return [["svgen", "sample", v, "--per-preset", str(PER_PRESET), *extra],
            ["svgen", "blend", v, b, "--count", str(BLENDS), *blend_args],
            ["svgen", "render", v, b, r, "--views", str(VIEWS)]]


def view_errors(model, src, indices, crop: int) -> dict:
    """Per-view normal RMSE of the model and of the flat map ((n+1)/2 encoding, centre crops), and the other maps'.

    Returns:
        {"normal", "flat", "rerender", "diffuse", "roughness", "specular"}: (V,) lists.
    """
    import torch

    from train.data import PairDataset
    from train.evaluate import metrics

    ds = PairDataset(src, indices, crop, 0, train=False)
    out = {k: [] for k in ("normal", "flat", "rerender", "diffuse", "roughness", "specular")}
    flat = torch.tensor([0.0, 0.0, 1.0])[:, None, None]
    with torch.no_grad():
        for lo in range(0, len(ds), 8):
            items = [ds[k] for k in range(lo, min(lo + 8, len(ds)))]
            img, gt = torch.stack([x[0] for x in items]), torch.stack([x[1] for x in items])
            m = metrics(model(img), gt)
            for k in ("normal", "rerender", "diffuse", "roughness", "specular"):
                out[k] += [round(float(v), 6) for v in m[k]]
            out["flat"] += [round(float(v), 6) for v in (((flat - gt[:, 0:3]) / 2) ** 2).mean((1, 2, 3)).sqrt()]
    return out


def spaced(idx: np.ndarray, n: int) -> np.ndarray:
    """At most ``n`` evenly spaced entries of ``idx``."""
    return idx if len(idx) <= n else idx[np.linspace(0, len(idx) - 1, n).round().astype(int)]


def run_arm(store: str, overrides: dict, steps: int, seed: int, eval_store: str | None = None,
            eval_crop: int | None = None) -> dict:
    """In a spawned process: train the compact preset with ``overrides`` for ``steps`` and measure it: on the
    held-out views of ``eval_store`` (default: ``store``; the same SVBRDFs are held out of stores rendered from the
    same variants and blends) and on training views, at centre crops of ``eval_crop`` (default: the training crop)."""
    import torch

    from train.config import resolve
    from train.data import PairDataset, open_source, split_by_source
    from train.evaluate import cluster_ids
    from train.fit import Trainer
    from train.net import count_parameters

    torch.set_num_threads(2)
    cfg = resolve("compact", None, {"data.store": store, "optim.iterations": steps, "optim.seed": seed,
                                    **PROBE_BASE, **overrides})
    src = open_source(cfg.data)
    train_idx, test_idx = split_by_source(src, cfg.data.holdout, cfg.data.split_seed)
    ds = PairDataset(src, train_idx, cfg.data.crop, cfg.optim.seed, train=True, flips=cfg.data.augment)
    trainer = Trainer(cfg)
    losses = []

    def train():
        for _, loss, _ in trainer.run(ds, 0, steps, timeout=300):
            losses.append(loss)

    _, _, train_s = timed(train)
    model = trainer.net.eval()
    # kept beside the stores for evaluations on other data (--cross): named by store, overrides, steps and seed
    key = hashlib.sha256(json.dumps([overrides, steps, seed], sort_keys=True).encode()).hexdigest()[:10]
    (Path(store).parent / "models").mkdir(exist_ok=True)
    torch.save({"config": cfg.to_dict(), "state": model.state_dict()},
               Path(store).parent / "models" / f"{Path(store).stem}_{key}.pt")
    crop = eval_crop or cfg.data.crop
    seen = spaced(train_idx, TRAIN_VIEWS)
    esrc = src
    if eval_store and eval_store != store:
        esrc = open_source(cfg.data.model_copy(update={"store": eval_store}))
        _, test_idx = split_by_source(esrc, cfg.data.holdout, cfg.data.split_seed)
        # no held-out SVBRDF of the evaluation store was trained on: both splits hold out the same sources
        assert set(cluster_ids(esrc, test_idx).tolist()).isdisjoint(cluster_ids(src, train_idx).tolist())
    held = spaced(test_idx, EVAL_VIEWS)
    return {"steps": steps, "seed": seed, "train_s": round(train_s, 1), "parameters": count_parameters(model),
            "loss_last_50": float(np.mean(losses[-50:])), "eval_crop": crop,
            "heldout": {**view_errors(model, esrc, held, crop), "svbrdf": cluster_ids(esrc, held).tolist()},
            "train": {**view_errors(model, src, seen, crop), "svbrdf": cluster_ids(src, seen).tolist()}}


def cross_eval(model_file: str, store: str, every: bool = False, crop: int | None = None) -> dict:
    """In a spawned process: a saved arm model on another store's held-out views (the grid's views of that store),
    or with ``every`` on all its views (at most EVAL_VIEWS, evenly spaced)."""
    import torch

    from train.config import from_dict
    from train.data import open_source, split_by_source
    from train.evaluate import cluster_ids
    from train.net import SVBRDFNet

    torch.set_num_threads(2)
    saved = torch.load(model_file, weights_only=False)
    cfg = from_dict(saved["config"])
    model = SVBRDFNet(cfg.model)
    model.load_state_dict(saved["state"])
    model.eval()
    cfg.data.store = store
    src = open_source(cfg.data)
    if every:  # a reference store: nothing of it was trained on
        test_idx = np.arange(len(src))
    else:
        _, test_idx = split_by_source(src, cfg.data.holdout, cfg.data.split_seed)
    held = spaced(test_idx, EVAL_VIEWS)
    return {**view_errors(model, src, held, crop or cfg.data.crop), "svbrdf": cluster_ids(src, held).tolist()}


def slope_spectrum(store: str, views: int = 32) -> dict:
    """Where the relief of a store's views lives: the share of the normals' slope power (x/z, y/z of the 128² centre
    crops the probes evaluate, zoom and rotation applied) by period, on ``views`` evenly spaced training views.

    Returns:
        {"period_px<=8", "period_px_8_32", "period_px>32"}: shares of the power; "flat_rmse": mean flat RMSE.
    """
    from train.config import resolve
    from train.data import PairDataset, open_source, split_by_source

    cfg = resolve("compact", None, {"data.store": store})
    src = open_source(cfg.data)
    train_idx, _ = split_by_source(src, cfg.data.holdout, cfg.data.split_seed)
    ds = PairDataset(src, spaced(train_idx, views), cfg.data.crop, 0, train=False)
    c = cfg.data.crop
    k = np.fft.fftfreq(c, 1.0 / c)
    period = c / np.maximum(np.hypot(*np.meshgrid(k, k)), 1e-9)  # pixels
    bands = {"period_px<=8": period <= 8, "period_px_8_32": (period > 8) & (period <= 32), "period_px>32": period > 32}
    acc, flat = dict.fromkeys(bands, 0.0), []
    for i in range(len(ds)):
        n = ds[i][1].numpy()[0:3]
        for sl in (n[0] / n[2], n[1] / n[2]):
            p = np.abs(np.fft.fft2(sl - sl.mean())) ** 2
            for b, m in bands.items():
                acc[b] += float(p[m].sum())
        flat.append(float(np.sqrt(np.mean(((n - np.array([0, 0, 1.0])[:, None, None]) / 2) ** 2))))
    tot = sum(acc.values())
    return {**{b: v / tot for b, v in acc.items()}, "flat_rmse": float(np.mean(flat)), "views": len(ds)}


def relative(runs: list[dict], split: str = "heldout", resamples: int = 2000, seed: int = 0,
             boot: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
    """Normal RMSE relative to flat over the views of ``split``, mean over seeds, with its bootstrap.

    Args:
        runs: one arm's runs (one per training seed), evaluated on the same views.
        boot: fixed resampling (cluster draws (R, C), seed draws (R, S)) so that two arms on the same views are
            resampled together; None draws them here.

    Returns:
        {"rel", "ci95", "normal", "flat", "draws"}: draws is (R,) rel per resample (for paired effects).
    """
    err = np.array([r[split]["normal"] for r in runs])  # (S, V)
    flat = np.asarray(runs[0][split]["flat"])
    ids, inv = np.unique(np.asarray(runs[0][split]["svbrdf"]), return_inverse=True)
    se = np.stack([np.bincount(inv, weights=e, minlength=len(ids)) for e in err])  # (S, C) per-SVBRDF sums
    sf = np.bincount(inv, weights=flat, minlength=len(ids))
    if boot is None:
        rng = np.random.default_rng(seed)
        boot = (rng.integers(0, len(ids), (resamples, len(ids))), rng.integers(0, len(runs), (resamples, len(runs))))
    cd, sd = boot
    draws = np.array([se[s][:, c].sum(1).mean() / sf[c].sum() for c, s in zip(cd, sd % len(runs))])
    lo, hi = np.quantile(draws, [0.025, 0.975])
    return {"rel": float(err.mean() / flat.mean()), "ci95": [float(lo), float(hi)], "normal": float(err.mean()),
            "flat": float(flat.mean()), "views": int(err.shape[1]), "svbrdfs": int(len(ids)), "seeds": len(runs),
            "draws": draws}


def summarise(results: dict, steps: int, resamples: int = 2000) -> dict:
    """Per arm: rel on held-out and training views; per factor arm: its effect against the baseline arm."""
    by = {}
    for r in results["runs"]:
        if r["steps"] == steps * ARMS[r["arm"]][3]:
            by.setdefault(r["arm"], []).append(r)
    out = {}
    rng = np.random.default_rng(0)
    for name, runs in by.items():
        factor, store, _, _, what = ARMS[name]
        base = by.get(baseline_of(name))
        row = {"factor": factor, "store": store, "what": what, "steps": runs[0]["steps"],
               "seeds": sorted(r["seed"] for r in runs)}
        for split in ("heldout", "train"):
            rel = relative(runs, split, resamples)
            row[split] = {k: v for k, v in rel.items() if k != "draws"}
            row[split]["other_maps"] = {k: float(np.mean([r[split][k] for r in runs]))
                                        for k in ("rerender", "diffuse", "roughness", "specular")}
        row["baseline"] = baseline_of(name)
        if base and name != baseline_of(name):
            n_c = len(np.unique(base[0]["heldout"]["svbrdf"]))
            if eval_store_of(name) == eval_store_of(baseline_of(name)):
                # same views: resample SVBRDFs together, seeds on their own
                cd = rng.integers(0, n_c, (resamples, n_c))
                a = relative(base, boot=(cd, rng.integers(0, 9999, (resamples, len(base)))))["draws"]
                b = relative(runs, boot=(cd, rng.integers(0, 9999, (resamples, len(runs)))))["draws"]
                paired = True
            else:
                a = relative(base, resamples=resamples, seed=1)["draws"]
                b = relative(runs, resamples=resamples, seed=2)["draws"]
                paired = False
            d = b - a
            row["effect"] = {"mean": row["heldout"]["rel"] - relative(base)["rel"],
                             "ci95": [float(x) for x in np.quantile(d, [0.025, 0.975])], "paired": paired}
        out[name] = row
    return out


def chart(summary: dict, png: Path, steps: int, choice: str, cross: dict | None = None) -> None:
    """Each arm's held-out normal RMSE relative to flat (with its interval), grouped by factor; with ``cross``, the
    arm's model on the real reference store too (``--cross ARM ref``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [n for n in ARMS if n in summary]
    fig, ax = plt.subplots(figsize=(8, 0.42 * len(names) + 1.5))
    colours = {"baseline": "0.3", "data": "tab:green", "network": "tab:blue", "loss": "tab:orange", "steps": "tab:purple",
               "combined": "tab:red"}
    for y, n in enumerate(names):
        r = summary[n]
        for split, mk, off in (("heldout", "o", 0.0), ("train", "x", 0.18)):
            v = r[split]
            ax.errorbar(v["rel"], y + off, xerr=[[v["rel"] - v["ci95"][0]], [v["ci95"][1] - v["rel"]]], fmt=mk,
                        color=colours[r["factor"]], alpha=1.0 if split == "heldout" else 0.5, capsize=2)
        c = (cross or {}).get(f"{n} on ref")
        if c:
            ax.errorbar(c["rel"], y - 0.18, xerr=[[c["rel"] - c["ci95"][0]], [c["ci95"][1] - c["rel"]]], fmt="^",
                        color="k", capsize=2, ms=4)
    ax.set_yticks(range(len(names)), [f"{n} ({summary[n]['factor']})" for n in names])
    ax.invert_yaxis()
    ax.axvline(1.0, color="k", lw=0.8)
    ax.axvline(0.75, color="tab:red", lw=0.8, ls="--")
    ax.text(0.75, len(names) - 0.4, " aim", color="tab:red", fontsize=8)
    ax.text(1.0, len(names) - 0.4, " flat", fontsize=8)
    ax.set_xlabel(f"normal RMSE / flat map's (o held-out, x training views, ^ real CC0 reference; 95 % interval), "
                  f"{steps} steps", fontsize=8)
    ax.set_title(f"Learning shape: one factor at a time (compact preset at width 8, 128² crops;\nnow_*: round 2, "
                 f"width 16, today's library, whole 256² views evaluated)\n" + textwrap.fill(f"Choice: {choice}", 90),
                 fontsize=9)
    fig.tight_layout()
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=110)
    plt.close(fig)


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--build", metavar="DIR", help="build the probe stores under DIR and exit")
    ap.add_argument("--only", nargs="+", choices=list(STORES), default=list(STORES), metavar="STORE",
                    help="with --build: only these stores (and nothing they do not need)")
    ap.add_argument("--stores", metavar="DIR", help="the folder --build wrote")
    ap.add_argument("--arms", nargs="+", default=list(ARMS), choices=list(ARMS))
    ap.add_argument("--steps", type=int, default=600, help="probe steps (the steps arms multiply them)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--out", default=str(RESULTS / "shape.json"))
    ap.add_argument("--png", default=str(IMG / "chart_shape.png"))
    ap.add_argument("--choice", default="", help="the choice made, for the chart's title and shape.json")
    ap.add_argument("--chart", action="store_true", help="only redraw the chart from --out")
    ap.add_argument("--cross", nargs=2, metavar=("ARM", "STORE"),
                    help="evaluate ARM's saved model (seed 0, --steps) on the held-out views of store STORE (a name "
                         "of STORES) or on every view of DIR/STORE_r.zarr (another name: 'ref', the CC0 reference "
                         "made by svgen import ../shared/materials-cc0 + svgen render --views 4); recorded under 'cross'")
    ap.add_argument("--spectra", action="store_true",
                    help="record where each store's relief lives (slope power by period in the probe's crops)")
    ap.add_argument("--merge", nargs="+", default=[], metavar="JSON",
                    help="add the runs (and commands) of these results files to --out first (grids run in parallel)")
    a = ap.parse_args(argv)
    if a.build:
        root = Path(a.build)
        root.mkdir(parents=True, exist_ok=True)
        for name in with_parents(a.only):
            if not store_path(root, name).exists():
                for cmd in build_commands(root, name):
                    subprocess.run(cmd, check=True)
        return
    out = Path(a.out)
    old = json.loads(out.read_text()) if out.exists() else {}
    results = {"runs": old.get("runs", []), "commands": old.get("commands", [])}
    for f in a.merge:
        other = json.loads(Path(f).read_text())
        have = {(r["arm"], r["seed"], r["steps"]) for r in results["runs"]}
        results["runs"] += [r for r in other["runs"] if (r["arm"], r["seed"], r["steps"]) not in have]
        results["commands"] += [c for c in other.get("commands", []) if c not in results["commands"]]
    results["cross"] = old.get("cross", {})
    results["spectra"] = old.get("spectra", {})
    for f in a.merge:
        results["spectra"].update(json.loads(Path(f).read_text()).get("spectra", {}))
    if a.spectra:
        for name in STORES:
            if store_path(Path(a.stores), name).exists():
                results["spectra"][name] = slope_spectrum(str(store_path(Path(a.stores), name)))
                print(name, json.dumps(results["spectra"][name]), flush=True)
    for f in a.merge:
        results["cross"].update(json.loads(Path(f).read_text()).get("cross", {}))
    if a.cross:
        arm, target = a.cross
        _, store, overrides, mult, _ = ARMS[arm]
        root = Path(a.stores)
        key = hashlib.sha256(json.dumps([overrides, a.steps * mult, 0], sort_keys=True).encode()).hexdigest()[:10]
        with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as ex:
            r = ex.submit(cross_eval, str(root / "models" / f"{store}_r_{key}.pt"), str(store_path(root, target)),
                          target not in STORES, eval_crop_of(arm)).result()
        rel = relative([{"heldout": r}])
        results["cross"][f"{arm} on {target}"] = {"arm": arm, "store": target, "steps": a.steps * mult,
                                                  **{k: v for k, v in rel.items() if k != "draws"}, "views": r}
        print(f"{arm} on {target}: rel {rel['rel']:.3f} {rel['ci95']}")
    elif not a.chart and not a.spectra:
        if not a.stores:
            ap.error("--stores DIR is needed to train (or --chart to redraw)")
        root = Path(a.stores)
        done = {(r["arm"], r["seed"], r["steps"]) for r in results["runs"]}
        for arm in a.arms:
            _, store, overrides, mult, _ = ARMS[arm]
            for seed in a.seeds:
                if (arm, seed, a.steps * mult) in done:
                    continue
                path, epath = store_path(root, store), store_path(root, eval_store_of(arm))
                for p in {path, epath}:
                    if not p.exists():
                        sys.exit(f"bench_shape: no store {p}; build it with --build {root}")
                # one spawned process per run: a process that has run drjit must not fork loader workers
                with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as ex:
                    r = ex.submit(run_arm, str(path), overrides, a.steps * mult, seed, str(epath),
                                  eval_crop_of(arm)).result()
                results["runs"].append({"arm": arm, **r})
                h = relative([r])
                print(f"{arm:18s} seed {seed} steps {r['steps']}: held-out rel {h['rel']:.3f} "
                      f"train rel {relative([r], 'train')['rel']:.3f} ({r['train_s']} s)", flush=True)
                write_results(out, _payload(results, a), a.note)
    if not a.chart:
        results["commands"].append(" ".join(["python3", "experiments/shape/bench_shape.py", *(argv or sys.argv[1:])]))
    write_results(out, _payload(results, a), a.note)
    s = json.loads(out.read_text())
    chart(s["summary"], Path(a.png), a.steps, s.get("choice") or a.choice, s.get("cross"))
    for n, r in s["summary"].items():
        e = r.get("effect")
        print(f"{n:18s} held-out {r['heldout']['rel']:.3f} {r['heldout']['ci95']}  train {r['train']['rel']:.3f}"
              + (f"  effect {e['mean']:+.3f} [{e['ci95'][0]:+.3f}, {e['ci95'][1]:+.3f}]" if e else ""))


def _relative_paths(cmd: str) -> str:
    """A recorded command without absolute paths (results files must not hold them): DIR/<name> for each."""
    return " ".join("DIR/" + Path(t).name if t.startswith("/") else t for t in cmd.split())


def _payload(results: dict, a) -> dict:
    return {"command": _relative_paths(" ".join(["python3", "experiments/shape/bench_shape.py", *sys.argv[1:]])),
            "probe": {"preset": "compact", "crop": 128, "steps": a.steps, "per_preset": PER_PRESET, "blends": BLENDS,
                      "views": VIEWS, "stores": {k: {"relief": v[0], "relief_cycles": v[1]} for k, v in STORES.items()},
                      "build": {n: [" ".join(c[:2] + [Path(x).name if x.endswith(".zarr") else x for x in c[2:]])
                                    for c in build_commands(Path("DIR"), n)] for n in STORES}},
            "arms": {k: {"factor": v[0], "store": v[1], "overrides": v[2], "steps_x": v[3], "what": v[4]}
                     for k, v in ARMS.items()},
            "choice": a.choice, "commands": [_relative_paths(c) for c in results["commands"]],
            "summary": summarise(results, a.steps),
            "cross": results.get("cross", {}), "spectra": results.get("spectra", {}),
            "runs": results["runs"]}


if __name__ == "__main__":
    main()
