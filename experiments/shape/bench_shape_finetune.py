"""#22 on real materials: what a data or training change does to the normals, one change at a time, by fine-tuning.

From-scratch probes at an affordable length (``bench_shape.py``: 600 steps) hardly leave the flat map, so their
effects sit inside their intervals. Here every arm starts from the same trained weights (the bundled model,
``svtrain fit --init bundled``) and trains the same number of steps with one thing changed, so what differs between
arms is that change alone, at a fraction of a from-scratch run's CPU time.

Each arm, every step the command a user runs:

1. its training store: ``svgen sample`` / ``blend`` / ``render --params params.yaml`` with the arm's ``sample``
   settings (``--set``), in ``WORK/stores/<store>/`` (reused when finished; arms with the same settings share it);
2. ``svtrain fit --params params.yaml --store S --init bundled --iterations N`` plus the arm's ``train`` settings,
   in ``WORK/runs/<arm>`` (reused when finished);
3. ``svtrain eval`` of the run on the control store's held-out split (the same views for every arm: materials no arm
   trained on, the split being by preset) and on the real reference at each ``--crops`` fraction
   (``svgen reference REF --crop C``, every view).

Results (``experiments/shape/results/shape_finetune.json``, chart ``docs/img/chart_shape_finetune.png``): per arm and
evaluation set the RMSE of every column beside the flat/constant baselines; the normal RMSE relative to the flat
map's; per reference material the normal RMSE of each arm beside the flat map's; and each arm's effect on the
normal RMSE against the control (control minus arm: positive is better), with a 95 % bootstrap interval over
materials (``train.evaluate.paired``).

    python3 experiments/shape/bench_shape_finetune.py                      # every arm, 1,500 steps each
    python3 experiments/shape/bench_shape_finetune.py --arms control decorrelated --steps 1500
"""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np

# harness.py (and freshness.py) stay in benchmarks/, the sim-to-real driver is experiments/sim2real/'s: this finished
# experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "sim2real"))
from bench_sim2real import DEFAULT_REF, _done, _rel, sh  # noqa: E402
from harness import IMG, ROOT, parser, pyplot, save_figure, write_results  # noqa: E402

#: this experiment's frozen results (experiments/shape/results/)
RESULTS = Path(__file__).resolve().parent / "results"

COLUMNS = ("normal", "diffuse", "roughness", "specular", "rerender")
#: store name -> the sample settings it is made with (every relief key explicit, so that a change of the
#: params.yaml defaults does not change what an arm measures).
STORES = {
    "base": {"flat_share": 0.0, "swap_share": 0.0},
    "dec25": {"flat_share": 0.25, "swap_share": 0.25},
    "dec35": {"flat_share": 0.35, "swap_share": 0.35},
    "flat35": {"flat_share": 0.35, "swap_share": 0.0},
}
#: arm -> (store, train settings, what it tests).
ARMS = {
    "control": ("base", {}, "the library as it was (every variant's own relief)"),
    "decorrelated": ("dec25", {}, "25 % of variants with flat normals (colour kept), 25 % with an independent "
                                  "random relief"),
    "decorrelated_strong": ("dec35", {}, "35 % flat normals, 35 % independent relief"),
    "flat_only": ("flat35", {}, "35 % flat normals, no independent relief (which of the two does the work)"),
    "centre_crops": ("base", {"data.crop_at": "centre"}, "training crops at the view's centre (the evaluated "
                                                         "window's capture geometry)"),
    # against decorrelated_strong (its store): the loss's normal term as the evaluation's metric. Weight 30: the
    # same gradient as the l2 term at weight 100 for a sample of RMSE 0.03, d(100 * 6 R^2)/dR = 1200 R = 36
    "rmse_term": ("dec35", {"optim.normal_loss": "rmse", "optim.normal_l2": 30.0},
                  "decorrelated_strong's data, the normal term as each sample's RMSE (the evaluation's metric)"),
}


def build_store(work: Path, name: str, params: str, log: list) -> Path:
    """The training store ``name`` of :data:`STORES` (reused when finished)."""
    d = work / "stores" / name
    d.mkdir(parents=True, exist_ok=True)
    sets = [x for k, v in STORES[name].items() for x in ("--set", f"{k}={v}")]
    v, b, r = d / "variants.zarr", d / "blends.zarr", d / "renders.zarr"
    for out, cmd in ((v, ["svgen", "sample", str(v), *sets]), (b, ["svgen", "blend", str(v), str(b)]),
                     (r, ["svgen", "render", str(v), str(b), str(r)])):
        if not _done(out):
            sh([*cmd, "--params", params], log)
    return r


def fine_tune(work: Path, arm: str, store: Path, steps: int, params: str, log: list) -> Path:
    """The arm's run: ``steps`` steps from the bundled weights (reused when a finished run of those steps is there)."""
    run = work / "runs" / arm
    m = run / "metrics.json"
    sets = [x for k, v in ARMS[arm][1].items() for x in ("--set", f"{k}={v}")]
    cmd = ["svtrain", "fit", "--params", params, "--store", str(store), "--out", str(run), "--init", "bundled",
           "--iterations", str(steps), "--no-resume", *sets]
    if m.is_file() and json.loads(m.read_text()).get("done") and json.loads(m.read_text())["step"] == steps:
        clock = json.loads((run / "timing.json").read_text()) if (run / "timing.json").is_file() else \
            json.loads(m.read_text())  # the run's clock (train/timing.py); metrics.json held it before
        log.append({"cmd": " ".join(_rel(c) for c in cmd), "reused": True,
                    "train_wall_s": round(clock["train_wall_s"], 1)})
    else:
        sh(cmd, log)
    return run


def evaluate(run: Path, name: str, store: Path, suite: str, log: list) -> dict:
    """``svtrain eval`` of ``run`` on ``store`` into ``run/eval_<name>``: eval.json and the per-view errors."""
    ev = run / f"eval_{name}"
    if not (ev / "eval.json").is_file():
        sh(["svtrain", "eval", "--checkpoint", str(run), "--store", str(store), "--suite", suite, "--out", str(ev)],
           log)
    res = json.loads((ev / "eval.json").read_text())
    rows = [line.split(",") for line in (ev / "per_view.csv").read_text().splitlines()[1:]]
    res["per_view_normal"] = {int(r[1]): float(r[4]) for r in rows}  # view -> the model's normal RMSE
    res["per_view_svbrdf"] = {int(r[1]): int(r[2]) for r in rows}
    return res


def flat_per_view(store: Path, crop: int = 128) -> tuple[dict[int, float], list[str]]:
    """Each view's flat-map normal RMSE (the evaluated centre window, (n+1)/2 encoding) and each SVBRDF's name."""
    import torch

    from storage.renders_store import RendersReader
    from train.data import PairDataset

    src = RendersReader(str(store))
    ds = PairDataset(src, np.arange(len(src)), crop, train=False)
    out = {}
    for i in range(len(src)):
        n = ds[i][1][0:3]
        flat = torch.zeros_like(n)
        flat[2] = 1.0
        out[i] = float((((n - flat) * 0.5) ** 2).mean().sqrt())
    return out, [p[0].split("/")[-1] for p in src.presets_of_svbrdf()]


def effect(arm: dict, control: dict) -> dict:
    """Control minus arm normal RMSE (positive: the arm is better), 95 % bootstrap over SVBRDFs."""
    from train.evaluate import paired

    views = sorted(arm["per_view_normal"])
    p = paired([arm["per_view_normal"][v] for v in views], [control["per_view_normal"][v] for v in views],
               np.array([arm["per_view_svbrdf"][v] for v in views]), seed=0)
    return {"gain": round(p["gain"], 5), "ci95": [round(x, 5) for x in p["ci95"]], "clusters": p["clusters"]}


def chart(result: dict, path: Path) -> None:
    """Per evaluation set, each arm's normal RMSE relative to the flat map's (1 = flat; lower is better)."""
    plt = pyplot()
    sets = list(result["sets"])
    arms = list(result["arms"])
    fig, ax = plt.subplots(figsize=(9, 3.6), dpi=110)
    w = 0.8 / len(arms)
    for k, arm in enumerate(arms):
        vals = [result["arms"][arm]["sets"][s]["normal_rel_flat"] for s in sets]
        bars = ax.bar(np.arange(len(sets)) + (k - (len(arms) - 1) / 2) * w, vals, w, label=arm)
        for b_, v in zip(bars, vals):
            ax.text(b_.get_x() + b_.get_width() / 2, v + 0.004, f"{v:.3f}", ha="center", fontsize=6.5)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xticks(range(len(sets)), [result["sets"][s] for s in sets], fontsize=8)
    ax.set_ylabel("normal RMSE / flat map's")
    lo = min(result["arms"][a]["sets"][s]["normal_rel_flat"] for a in arms for s in sets)
    ax.set_ylim(min(0.8, lo - 0.03), None)
    ax.set_title(f"#22: fine-tuning the bundled model {result['steps']} steps, one change per arm", fontsize=9)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    save_figure(fig, path)


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--arms", nargs="+", default=list(ARMS), choices=list(ARMS))
    ap.add_argument("--steps", type=int, default=1500, help="fine-tuning steps per arm")
    ap.add_argument("--reference", default=os.environ.get("SVGEN_REFERENCE_DIR") or str(DEFAULT_REF),
                    help="real material folders (default: SVGEN_REFERENCE_DIR, else ../shared/materials-cc0)")
    ap.add_argument("--crops", type=float, nargs="+", default=[1.0, 0.5], help="reference crop fractions")
    ap.add_argument("--work", default=str(ROOT / "runs" / "shape_finetune"), help="scratch folder")
    ap.add_argument("--out", default=str(RESULTS / "shape_finetune.json"))
    ap.add_argument("--png", default=str(IMG / "chart_shape_finetune.png"))
    a = ap.parse_args(argv)
    ref = Path(a.reference)
    if not ref.is_dir():
        raise SystemExit(f"no reference folder at {ref} (--reference or SVGEN_REFERENCE_DIR)")
    if "control" not in a.arms:
        a.arms = ["control", *a.arms]  # every effect is against it
    from train.bundled_model import manifest

    work, params, log = Path(a.work), str(ROOT / "params.yaml"), []
    work.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    base = build_store(work, "base", params, log)
    sets = {"heldout": (base, "heldout", "svgen held-out")}
    for crop in a.crops:
        rd = work / f"ref_crop{crop:g}"
        if not _done(rd / "renders.zarr"):
            sh(["svgen", "reference", str(ref), str(rd), "--params", params, "--crop", str(crop)], log)
        sets[f"ref_crop{crop:g}"] = (rd / "renders.zarr", "all", f"real, crop {crop:g}")
    flat = {k: flat_per_view(s) for k, (s, _, _) in sets.items()}
    evals: dict[str, dict] = {}
    for arm in a.arms:
        run = fine_tune(work, arm, build_store(work, ARMS[arm][0], params, log), a.steps, params, log)
        evals[arm] = {k: evaluate(run, k, s, suite, log) for k, (s, suite, _) in sets.items()}
    result = {"protocol": {"start": "the bundled model (svtrain fit --init bundled)",
                           "bundled_sha256": manifest().get("sha256"), "steps": a.steps,
                           "heldout": "the control store's held-out split (the same views for every arm)",
                           "reference": f"{ref.name} at crops {', '.join(f'{c:g}' for c in a.crops)}, every view"},
              "steps": a.steps, "stores": {k: STORES[k] for k in {ARMS[x][0] for x in a.arms}},
              "sets": {k: v[2] for k, v in sets.items()}, "arms": {}}
    for arm in a.arms:
        entry = {"store": ARMS[arm][0], "train_settings": ARMS[arm][1], "what": ARMS[arm][2], "sets": {}}
        for k, res in evals[arm].items():
            f = res["input_as_diffuse"]["normal"]
            entry["sets"][k] = {"model": {c: round(res["model"][c], 5) for c in COLUMNS},
                                "flat_or_constant": {c: round(min(res["input_as_diffuse"][c], res["dataset_mean"][c]),
                                                              5) for c in COLUMNS},
                                "normal_rel_flat": round(res["model"]["normal"] / f, 4),
                                "normal_effect_vs_control": None if arm == "control" else
                                effect(res, evals["control"][k])}
        result["arms"][arm] = entry
    first_ref = next(k for k in sets if k.startswith("ref_"))
    views, names = flat[first_ref]
    per_mat: dict[str, dict] = {}
    for arm in a.arms:
        pv, sv = evals[arm][first_ref]["per_view_normal"], evals[arm][first_ref]["per_view_svbrdf"]
        for v, e in pv.items():
            d = per_mat.setdefault(names[sv[v]], {"flat": [], **{x: [] for x in a.arms}})
            d[arm].append(e)
            if arm == a.arms[0]:
                d["flat"].append(views[v])
    result["per_material"] = {"set": first_ref, "normal_rmse": {
        m: {k: round(float(np.mean(v)), 5) for k, v in d.items()}
        for m, d in sorted(per_mat.items(), key=lambda kv: -np.mean(kv[1]["flat"]))}}
    result["commands"] = log
    result["total_wall_s"] = round(time.perf_counter() - t0, 1)
    write_results(a.out, result, a.note)
    chart(result, Path(a.png))
    for arm, e in result["arms"].items():
        print(arm.ljust(22), "  ".join(f"{k} {v['normal_rel_flat']:.3f}" for k, v in e["sets"].items()))


if __name__ == "__main__":
    main()
