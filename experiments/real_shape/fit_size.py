"""Round 11 of issue #39: can this network fit its own training views' normals at all, and at what training-set size?

Every arm of rounds 1-10 left its own training views' normals at 0.93-0.996 of the flat map's error, so by the
issue's criterion none could show a normal effect. This asks what that failure is: a network that cannot fit
normals (capacity, loss, inputs), or too little training per material on 2 cores. Each arm trains from scratch with
params.yaml's train config (the bundled model's recipe) for the same steps, seed and lr on the default store, and
differs only in ``data.holdout``: how many of the store's materials it trains on. Fewer materials = more passes over
each in the same steps.

Evaluation (``svtrain eval``): each arm's own training views (``--suite train``, the first 100), its own held-out
split (the first 200 views; the splits differ with the holdout, so these are unseen svgen views, not the same views),
and the real reference (both folds of ``control.py``, 320 views; no arm saw a real material).

    python3 experiments/real_shape/fit_size.py --work runs/rs --out-dir runs/fs --steps 3000 --arms h98 h90
    python3 experiments/real_shape/fit_size.py --work runs/rs --out-dir runs/fs --steps 3000   # then h95, h98_more

Round 12 pairs two of these arms with data arms (``DATA_ARMS``) on soft_store.py's store, which differs from the
default store only in each SVBRDF's diffuse (half its contrast about its mean): same materials, split, views and
seeds. Each data arm is evaluated on both stores' training views, the control store's held-out views and the real
reference, and so is the arm it is paired with; effects are paired per view, 95 % intervals over materials.

    python3 experiments/real_shape/soft_store.py --work runs/dc --control runs/rs/train/renders.zarr
    python3 experiments/real_shape/fit_size.py --work runs/rs --out-dir runs/fs --steps 3000 --arms h90 h90_soft \
        --arm-store h90_soft=runs/dc/renders.zarr --out experiments/real_shape/results/fit_soft.json   # and h98

A checkpoint copied while the fits run (``cp OUT/ARM/checkpoint.pt OUT/mid_ARM/ckpt.pt``; here at step 1,600) is
evaluated on the training views too: the middle of the fit curve.

Finished runs and evaluations are reused; rerun to resume. Results: ``results/fit_size.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).parent))

from control import COLUMNS, PARAMS, arm_stores, evaluate, pooled_effect, side_by_side, table  # noqa: E402

#: arm -> (data.holdout, the arm whose model it starts from or None: from scratch). On runs/rs/train, the default
#: library's store, 0.1 trains on 7,030 views of 796 SVBRDFs, 0.9 on 550 views (55 SVBRDFs), 0.95 on 280 (28), 0.98 on
#: 120 (12). ``h98_more`` is a second cycle of h98 (its model, the same steps and schedule again): is the fit still
#: falling at 400 passes?
ARMS = {"h98": (0.98, None), "h90": (0.9, None), "h95": (0.95, None), "h98_more": (0.98, "h98"),
        "h90_soft": (0.9, None), "h98_soft": (0.98, None)}
#: data arms (round 12): arm -> (the arm it is paired with, what its store changes). They train on ``--arm-store
#: NAME=STORE``, a store with the control's materials, split and views; both models are evaluated on both stores'
#: training views and on the control store's held-out views.
SOFT = "soft_store.py's store: every SVBRDF's diffuse at half its contrast about its mean, all else the control store's"
DATA_ARMS = {"h90_soft": ("h90", SOFT), "h98_soft": ("h98", SOFT)}
TRAIN_VIEWS, HELDOUT_VIEWS = 100, 200


def over_best_baseline(ev: dict) -> dict:
    """Each column's RMSE over the better of its two baselines (the dataset mean, the input as diffuse): how well
    each map is fitted, on one scale (the normal's baselines are both the flat map)."""
    return {c: round(ev["model"][c] / min(ev["dataset_mean"][c], ev["input_as_diffuse"][c]), 3) for c in COLUMNS}


def fit_cmd(a, store: Path, out: Path, arm: str) -> list[str]:
    holdout, init = ARMS[arm]
    return ["svtrain", "fit", "--params", PARAMS, "--store", str(store), "--out", str(out / arm),
            "--iterations", str(a.steps), "--workers", "0", "--set", f"optim.threads={a.threads}",
            "--set", f"data.holdout={holdout}", "--set", "optim.checkpoint_minutes=5",
            *(["--init", str(out / init / "model.pt")] if init else [])]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--work", default=str(ROOT / "runs" / "rs"), help="control.py's scratch folder")
    ap.add_argument("--out-dir", required=True, help="where the runs go")
    ap.add_argument("--steps", type=int, required=True)
    ap.add_argument("--threads", type=int, default=1, help="torch threads per run (every arm the same)")
    ap.add_argument("--arms", nargs="*", default=[n for n in ARMS if n not in DATA_ARMS],
                    help=f"arms (default: round 11's): {', '.join(ARMS)}")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "fit_size.json"))
    ap.add_argument("--arm-store", action="append", default=[], metavar="NAME=STORE",
                    help=f"the training store of a data arm ({', '.join(DATA_ARMS)})")
    a = ap.parse_args(argv)
    a.arm_store = arm_stores(a.arm_store, DATA_ARMS)
    missing = [n for n in a.arms if n in DATA_ARMS and n not in a.arm_store]
    if missing:
        raise SystemExit(f"data arms need --arm-store NAME=STORE: {', '.join(missing)}")
    unknown = [x for x in a.arms if x not in ARMS]
    if unknown:
        raise SystemExit(f"--arms: unknown {unknown}; choose from {', '.join(ARMS)}")
    work, out_dir = Path(a.work).resolve(), Path(a.out_dir).resolve()
    store, refs = work / "train" / "renders.zarr", sorted(work.glob("fold*/ref/renders.zarr"))
    if not store.is_dir() or not refs:
        raise SystemExit(f"{work} has no train/renders.zarr or fold*/ref/renders.zarr: run control.py --phase stores")
    out_dir.mkdir(parents=True, exist_ok=True)
    waiting = [n for n in a.arms if ARMS[n][1] and not (out_dir / ARMS[n][1] / "model.pt").is_file()]
    if waiting:
        raise SystemExit(f"{', '.join(waiting)} start from another arm's model: fit {ARMS[waiting[0]][1]} first")
    side_by_side({n: fit_cmd(a, a.arm_store.get(n, store), out_dir, n) for n in a.arms
                  if not (out_dir / n / "model.pt").is_file()}, out_dir, a.threads)
    log = out_dir / "commands.log"
    res = {"question": "does the network fit its own training views' normals when it trains on fewer materials for "
                       "the same steps (from scratch, params.yaml's recipe)?",
           "steps": a.steps, "threads_per_run": a.threads,
           "commands": {n: " ".join(fit_cmd(a, Path("STORE"), Path("OUT"), n)).replace(PARAMS, "params.yaml")
                        for n in a.arms}, "arms": {}}
    if any(n in DATA_ARMS for n in a.arms):
        res["question"] = ("round 12: does a diffuse texture at half its contrast (real photos hold 2.3-3.2x less "
                           "texture than svgen's, relief_visibility.py) let the network fit and read normals sooner? "
                           "Paired arms from scratch, same materials, views, seed and steps")
        for n in a.arms:
            made = a.arm_store[n].parent / "soft.json" if n in DATA_ARMS else None  # soft_store.py's record
            if made is not None and made.is_file():
                res.setdefault("arm_stores", {})[n] = json.loads(made.read_text())
    for n in a.arms:
        run = out_dir / n
        ev_train = evaluate(run, run / "eval_train", log, "--suite", "train", "--limit", str(TRAIN_VIEWS))
        r = {"holdout": ARMS[n][0], "init": ARMS[n][1], "train_views": table(ev_train),
             # keyed by the steps the model has trained in all (a second cycle: twice the steps)
             "train_views_over_best_baseline": {str(a.steps * (2 if ARMS[n][1] else 1)):
                                                over_best_baseline(ev_train)},
             "heldout": table(evaluate(run, run / "eval_heldout", log, "--limit", str(HELDOUT_VIEWS)))}
        mid = out_dir / f"mid_{n}" / "ckpt.pt"  # a 5-minute checkpoint copied mid-run by hand: the curve's middle
        if mid.is_file():
            ev_mid = evaluate(mid, mid.parent / "eval_train", log, "--suite", "train", "--limit", str(TRAIN_VIEWS))
            step = int(torch.load(mid, weights_only=False)["step"])
            r["train_views_over_best_baseline"] = {str(step): over_best_baseline(ev_mid),
                                                   **r["train_views_over_best_baseline"]}
        for i, ref in enumerate(refs):
            r[f"reference_{i}"] = table(evaluate(run, run / f"eval_ref{i}", log, "--store", str(ref)))
        if n in DATA_ARMS:  # both models on both stores' views (the same materials, split and view indices)
            base, own = out_dir / DATA_ARMS[n][0], a.arm_store[n]
            r["paired_with"], r["what"] = DATA_ARMS[n]
            tr, ho = ("--suite", "train", "--limit", str(TRAIN_VIEWS)), ("--suite", "heldout", "--limit",
                                                                          str(HELDOUT_VIEWS))
            r["train_views_control_store"] = table(evaluate(run, run / "eval_train_control_store", log, *tr,
                                                            "--store", str(store)))
            r["heldout_control_store"] = table(evaluate(run, run / "eval_heldout_control_store", log, *ho,
                                                        "--store", str(store)))
            r["base_on_arm_store"] = {
                "train_views": table(evaluate(base, base / f"eval_train_{n}", log, *tr, "--store", str(own))),
                "heldout": table(evaluate(base, base / f"eval_heldout_{n}", log, *ho, "--store", str(own)))}
            # positive = the arm better, 95 % intervals over materials (control.pooled_effect)
            r["effect"] = {
                "train_views_own_store": pooled_effect([(base / "eval_train", run / "eval_train")]),
                "train_views_control_store": pooled_effect([(base / "eval_train", run / "eval_train_control_store")]),
                "train_views_arm_store": pooled_effect([(base / f"eval_train_{n}", run / "eval_train")]),
                "heldout_control_store": pooled_effect([(base / "eval_heldout", run / "eval_heldout_control_store")]),
                "reference": pooled_effect([(base / f"eval_ref{i}", run / f"eval_ref{i}") for i in range(len(refs))])}
        clock = json.loads((run / "timing.json").read_text())  # the training clock (train/timing.py)
        r["train_wall_s"], r["train_cpu_s"] = round(clock["train_wall_s"]), round(clock["train_cpu_s"])
        res["arms"][n] = r
        print(n, {k: v["normal_over_flat"] for k, v in r.items() if isinstance(v, dict) and "normal_over_flat" in v},
              flush=True)
    Path(a.out).parent.mkdir(exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
