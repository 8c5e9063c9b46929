"""Learning arms of issue #39, paired by fine-tuning: every arm starts from the bundled model (12,000 steps) and trains
the same steps on the same store with the same seed; what differs is the arm's one change.

The real-data control (``control.py``) showed that 3,000 steps from scratch do not fit the training views' normals,
so no arm trained that way can show an effect. Starting every arm from the bundled model, which already reads
relief on svgen's views (13 % below flat on its held-out split), puts every arm past that bar at a 2-core budget.
Network arms started from the same function: ``svtrain fit --init`` grew the normal decoder as a copy of the decoder,
and the pixel coordinates and the highlight cue's channel with zero weights, so each arm's first model *was* the
control's. All three lost and were removed in #41 with that growth; commit 614fe8c runs them.

Arms (``ARMS``): ``control`` (params.yaml's train config) and the network/loss changes, each a list of
``svtrain fit`` arguments added to the control's command.

Evaluation (``svtrain eval``), every arm on the same views:
- the real reference: the 32 CC0 materials at crop 1, the training views (``control.py``'s two fold stores; no arm
  trained on any real material, so all 32 are unseen);
- svgen held-out: the store's held-out split (the same split for every arm);
- training views (``--suite train``): can the arm fit what it saw?
and the bundled model itself on the same sets (where every arm started). Effects are arm minus control per view,
positive = the arm is better, with 95 % bootstrap intervals over materials (:func:`train.evaluate.paired`).

    python3 experiments/real_shape/control.py --work runs/rs --steps 0 --phase stores   # the stores, once
    python3 experiments/real_shape/finetune.py --work runs/rs --out-dir runs/ft --steps 3000
    python3 experiments/real_shape/finetune.py --work runs/rs --out-dir runs/ft --steps 3000 --phase eval

Finished runs and evaluations are reused; rerun to resume. Results: ``results/finetune_<steps>.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).parent))

from control import COLUMNS, PARAMS, arm_stores, evaluate, pooled_effect, side_by_side, table  # noqa: E402

#: arm -> the `svtrain fit` arguments it adds to the control's, and what it tests.
ARMS = {
    "control": ([], "the bundled model trained on with params.yaml's train config"),
    "spec_grad": (["--set", "optim.spec_grad=5"],
                  "round 9: + 5 x L1 on the specular map's neighbour differences against the truth's "
                  "(train.fit.spec_grad_term): the rendering loss pays for a specular copied from the photo "
                  "(spec_sensitivity.py), this term prices it; on the control's training views it is 5 x 0.0046 = "
                  "0.023, about 3x what the copy saves in rendering loss (0.008)"),
    "spec_grad1": (["--set", "optim.spec_grad=1"],
                   "round 10: spec_grad's dose: round 9's term at a fifth of its weight (1 x 0.0046 on the control's "
                   "training views, below the 0.008 the copy saves in rendering loss): does a weight cut the copy "
                   "without round 9's cost on the real re-render and roughness?"),
    "ndec": (["--set", "model.normal_decoder=true"],
             "(removed in #41; run at commit 614fe8c) a second decoder for the normal (SVBRDF-GAN's fix for flat "
             "normals), grown as a copy of the first"),
    "mixed": (["--set", "optim.map_l1=0.1"],
              "the 2019 mixed loss: + 0.1 x L1 on the maps (direct supervision of a grey, flat specular where the "
              "render loss lets diffuse texture leak into it)"),
    "coords": (["--set", "model.coord_channels=true"],
               "(removed in #41; run at commit 614fe8c) pixel coordinates as two input channels (CoordConv, the 2019 "
               "follow-up), each crop's pixels at their positions in the view, so they say where the flash is; grown "
               "from the bundled model with zero weights"),
    "rmse_late": (["--set", "optim.normal_late_loss=rmse", "--set", "optim.normal_late_from=0.3"],
                  "the normal term as each sample's RMSE from 30 % of the run on: false relief costs as the "
                  "evaluation counts it"),
    "cue": (["--set", "model.highlight_cue=true"],
            "(removed in #41; run at commit 614fe8c) round 8: the photo minus a highlight-suppressed copy as one "
            "more input channel (model.highlight_cue: the white top-hat of the darkest channel over 5 px), small "
            "white detail that a grey specular puts on relief and a coloured albedo does not; grown from the bundled "
            "model with zero weights"),
}

#: data arms: the control's train config on another store (``--arm-store NAME=PATH``), made like the control's with
#: one sample setting changed. Their held-out views differ from the control's where the change reaches them, so both
#: models are evaluated on both held-out sets (``heldout`` on the arm's store, ``heldout_control_store``).
DATA_ARMS = {
    "flat": ([], "the control's store remade with sample.flat_grain=false: the flat-mode variants (35 %) without the "
                 "fine grain, truly flat like a print or a polished stone (with the grain the library holds no flat "
                 "material)"),
    "flat_rmse_late": (ARMS["rmse_late"][0], "both winners of round 4 together: the flat store (--arm-store "
                                             "flat_rmse_late=<the flat arm's store>) and the late rmse normal term"),
    "flat_rmse_late_mixed": (ARMS["rmse_late"][0] + ARMS["mixed"][0],
                             "round 4's pair with the diffuse protected: the flat store, the late rmse normal term and "
                             "round 2's mixed loss (+ 0.1 x L1 on the maps, which helped specular and diffuse a little)"),
    "coarse": ([], "round 7 (the store needs commit 568d4b4): the control's store remade with "
                   "sample.coarse_relief=0.1 (coarse_share 0.5, 3 cycles per map): half the non-flat variants get relief at scales above 8 px, independent of colour, which "
                   "brings the library's share of slope energy there (1.6 %) to the real reference's (8 %; "
                   "coarse_share.py)"),
    "coarse_coords": (ARMS["coords"][0], "(removed in #41; run at commit 614fe8c) round 7: pixel coordinates (round "
                                         "3's coords arm) on the coarse store: coarse relief shades the view as the "
                                         "flash's fall-off does, and the coordinates say where the flash is"),
    "grey": ([], "(removed after the round; the store needs commit 547080c) round 9: the control's store remade "
                 "with sample.grey_specular=1: every preset variant's dielectric "
                 "pixels (specular luminance below 0.1) share one grey F0, the variant's mean; metal pixels keep "
                 "theirs, as real libraries' dielectrics have one grey F0"),
    "soft": ([], "round 12 (soft_store.py's store): every SVBRDF's diffuse at half its contrast about its own "
                 "mean, all else the control's store: the texture over the relief in the photo brought to the real "
                 "reference's (relief_visibility.py)"),
}
ARMS.update(DATA_ARMS)
#: arms also paired with another arm on the same store (what the one added change does on top of it)
BASES = {"flat_rmse_late_mixed": "flat_rmse_late", "coarse_coords": "coarse"}


#: views of each svgen set evaluated per model (``--limit``: the first of the suite's views; the real reference is
#: evaluated whole, 320 views): about 1.1 CPU-s a view on the 2-core machine, so 4 models x 3 sets fit in 25 minutes.
TRAIN_VIEWS, HELDOUT_VIEWS = 100, 200


def fit_cmd(a, store: Path, out: Path, extra: list[str]) -> list[str]:
    return ["svtrain", "fit", "--params", PARAMS, "--store", str(store), "--out", str(out), "--init", "bundled",
            "--iterations", str(a.steps), "--workers", "0", "--set", f"optim.threads={a.threads}",
            "--set", f"optim.lr={a.lr}", "--set", "optim.checkpoint_minutes=5", *extra]


def fit_arms(a, store: Path, out_dir: Path, arms: list[str]) -> None:
    """Train the unfinished arms side by side, one torch thread each (every arm the same arithmetic)."""
    side_by_side({n: fit_cmd(a, a.arm_store.get(n, store), out_dir / n, ARMS[n][0]) for n in arms
                  if not (out_dir / n / "model.pt").is_file()}, out_dir, a.threads)


def sets_of(run: str, out: Path, refs: list[Path], log: Path, store: Path) -> dict:
    """The figures of one model (a run folder or "bundled") on every evaluation set; ``out`` holds its evals."""
    r = {"train_views": table(evaluate(run, out / "eval_train", log, "--suite", "train", "--store", str(store),
                                       "--limit", str(TRAIN_VIEWS))),
         "heldout": table(evaluate(run, out / "eval_heldout", log, "--store", str(store), "--limit", str(HELDOUT_VIEWS)))}
    for i, ref in enumerate(refs):
        r[f"reference_{i}"] = table(evaluate(run, out / f"eval_ref{i}", log, "--store", str(ref)))
    return r


def spec(out: Path, refs: list[Path], heldout: tuple[str, ...] = ("eval_heldout",)) -> dict:
    """Median specular-copying statistics (``train.spec_stats``) of the model's maps and of the ground truth on the
    real reference and the held-out views (eval.json's ``specular_copy``; ``heldout``: those evaluations' folders)."""
    got = {}
    for name in [f"eval_ref{i}" for i in range(len(refs))] + list(heldout):
        ev = json.loads((out / name / "eval.json").read_text())["specular_copy"]
        got[name[5:]] = {who: {stat: round(q["median"], 3) for stat, q in ev[who].items()}
                         for who in ("model", "ground_truth")}
    return got


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--work", default=str(ROOT / "runs" / "real_shape"),
                    help="control.py's scratch folder: its train/renders.zarr and fold<i>/ref/renders.zarr are used")
    ap.add_argument("--out-dir", default=None, help="where the runs go (default WORK/finetune)")
    ap.add_argument("--steps", type=int, required=True)
    ap.add_argument("--lr", type=float, default=3e-4, help="Adam learning rate of every arm (cosine to 5 %%)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads per run (every arm the same)")
    ap.add_argument("--arms", nargs="*", default=list(ARMS), help=f"arms (control first): {', '.join(ARMS)}")
    ap.add_argument("--phase", choices=("all", "fit", "eval"), default="all")
    ap.add_argument("--out", default=None, help="results JSON (default results/finetune_<steps>.json here)")
    ap.add_argument("--arm-store", action="append", default=[], metavar="NAME=STORE",
                    help=f"the training store of a data arm ({', '.join(DATA_ARMS)})")
    a = ap.parse_args(argv)
    a.arm_store = arm_stores(a.arm_store, DATA_ARMS)
    missing = [n for n in a.arms if n in DATA_ARMS and n not in a.arm_store]
    if missing:
        raise SystemExit(f"data arms need --arm-store NAME=STORE: {', '.join(missing)}")
    unknown = [x for x in a.arms if x not in ARMS]
    if unknown or "control" not in a.arms:
        raise SystemExit(f"--arms: unknown {unknown} or no control; choose from {', '.join(ARMS)}")
    work = Path(a.work).resolve()
    out_dir = Path(a.out_dir).resolve() if a.out_dir else work / "finetune"
    out_dir.mkdir(parents=True, exist_ok=True)
    store = work / "train" / "renders.zarr"
    refs = sorted(work.glob("fold*/ref/renders.zarr"))
    if not store.is_dir() or not refs:
        raise SystemExit(f"{work} has no train/renders.zarr or fold*/ref/renders.zarr: run control.py --phase stores")
    log = out_dir / "commands.log"
    if a.phase in ("all", "fit"):
        fit_arms(a, store, out_dir, a.arms)
        if a.phase == "fit":
            return
    res = {"question": "which learning change reads real relief (and no false relief) better, fine-tuned from the "
                       "bundled model: paired arms, same store, seed, steps and lr",
           "steps": a.steps, "lr": a.lr, "threads_per_run": a.threads, "store": str(store.relative_to(work)),
           "references": [str(r.relative_to(work)) for r in refs],
           "commands": {n: " ".join(fit_cmd(a, Path("STORE"), Path("OUT") / n, ARMS[n][0]))
                        .replace(PARAMS, "params.yaml") for n in a.arms},
           "bundled": sets_of("bundled", out_dir / "bundled", refs, log, store), "arms": {}}
    ctl = out_dir / "control"
    unfinished = [n for n in a.arms if not (out_dir / n / "model.pt").is_file()]
    if unfinished:  # a checkpoint mid-run would be evaluated (and its evaluation reused) as if it were the arm
        raise SystemExit(f"arms not finished (no model.pt): {', '.join(unfinished)}; run --phase fit first")
    for name in a.arms:
        run = out_dir / name
        own = a.arm_store.get(name, store)
        r = {"what": ARMS[name][1], "args": ARMS[name][0], **sets_of(str(run), run, refs, log, own),
             "spec_stats": spec(run, refs)}
        if name != "control":
            r["effect_reference"] = pooled_effect([(ctl / f"eval_ref{i}", run / f"eval_ref{i}")
                                                   for i in range(len(refs))])
        if name in a.arm_store:  # both models on both held-out sets (same names; the arm's maps where it changed)
            r["store"] = os.path.relpath(own)  # relative to where it runs: results are not a function of paths
            ctl_on_arm = ctl / f"eval_heldout_{name}"
            on_ctl_store = run / "eval_heldout_control_store"
            lim = ("--limit", str(HELDOUT_VIEWS))
            evaluate(str(ctl), ctl_on_arm, log, "--suite", "heldout", "--store", str(own), *lim)
            r["heldout_control_store"] = table(evaluate(str(run), on_ctl_store, log, "--suite", "heldout",
                                                        "--store", str(store), *lim))
            r["effect_heldout"] = pooled_effect([(ctl_on_arm, run / "eval_heldout")])
            r["effect_heldout_control_store"] = pooled_effect([(ctl / "eval_heldout", on_ctl_store)])
        elif name != "control":
            r["effect_heldout"] = pooled_effect([(ctl / "eval_heldout", run / "eval_heldout")])
        base = BASES.get(name)
        if base in a.arms and a.arm_store.get(base, store) == own:
            r[f"effect_reference_vs_{base}"] = pooled_effect([(out_dir / base / f"eval_ref{i}", run / f"eval_ref{i}")
                                                            for i in range(len(refs))])
            r[f"effect_heldout_vs_{base}"] = pooled_effect([(out_dir / base / "eval_heldout", run / "eval_heldout")])
        res["arms"][name] = r
    # the control against where it started: what the steps alone did
    res["control_vs_bundled_reference"] = pooled_effect([(out_dir / "bundled" / f"eval_ref{i}", ctl / f"eval_ref{i}")
                                                         for i in range(len(refs))])
    out = Path(a.out) if a.out else Path(__file__).parent / "results" / f"finetune_{a.steps}.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(res, indent=1) + "\n")
    for name, r in res["arms"].items():
        print(name, {k: r[k]["normal_over_flat"] for k in r if isinstance(r[k], dict) and "normal_over_flat" in r[k]})
        if "effect_reference" in r:
            print("  effect on the reference:", {c: (r["effect_reference"][c]["gain"], r["effect_reference"][c]["ci95"])
                                                 for c in COLUMNS})
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
