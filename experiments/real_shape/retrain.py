"""Judge a retrained bundled model against the one svgen ships (issue #39, "Adopt what wins").

Both models are evaluated with the same code on the same views (``svtrain eval``):

- the real reference: the 32 CC0 materials at crop 1 (``control.py``'s two fold stores, 320 views; neither model
  trained on a real material, so all 32 are unseen);
- svgen held-out on two stores: the default library's (``runs/rs/train``, what the shipped model's card reports)
  and the retrain's own (e.g. the ``sample.flat_grain=false`` store), the first ``HELDOUT_VIEWS`` of each split;
- the retrain's own training views (``--suite train``): did it fit what it saw?

Effects are shipped minus retrain per view (positive: the retrain is better), with 95 % bootstrap intervals over
materials (:func:`control.pooled_effect`). The rule of adoption is the issue's: no column worse beyond its interval.

    python3 experiments/real_shape/retrain.py --run runs/retrain_r5/run --retrain-store runs/rsf/renders.zarr \\
        --work runs/rs --out-dir runs/retrain_r5/judge --name retrain_r5

Finished evaluations are reused (rerun to resume). Results: ``results/<name>.json``.
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

from control import COLUMNS, evaluate, pooled_effect, table  # noqa: E402
from finetune import HELDOUT_VIEWS, TRAIN_VIEWS, spec  # noqa: E402


def evaluations(run: str, out: Path, refs: list[Path], stores: dict[str, Path], log: Path) -> dict:
    """One model's figures: every reference fold (``eval_ref<i>``) and each store's held-out views
    (``eval_heldout_<name>``)."""
    r = {f"reference_{i}": table(evaluate(run, out / f"eval_ref{i}", log, "--store", str(ref)))
         for i, ref in enumerate(refs)}
    for name, store in stores.items():
        r[f"heldout_{name}"] = table(evaluate(run, out / f"eval_heldout_{name}", log, "--suite", "heldout",
                                              "--store", str(store), "--limit", str(HELDOUT_VIEWS)))
    return r


def verdict(effects: dict) -> dict:
    """Per effect set: the columns worse beyond noise (the adoption rule) and those better."""
    return {k: {"worse": [c for c in COLUMNS if e[c]["beyond_noise"] == "worse"],
                "better": [c for c in COLUMNS if e[c]["beyond_noise"] == "better"]} for k, e in effects.items()}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--run", required=True, help="the retrained run folder (its model.pt)")
    ap.add_argument("--retrain-store", required=True, help="the store the retrain trained on")
    ap.add_argument("--work", default=str(ROOT / "runs" / "real_shape"),
                    help="control.py's scratch folder: its train/renders.zarr and fold<i>/ref/renders.zarr are used")
    ap.add_argument("--out-dir", required=True, help="where the evaluations go (bundled/ and retrain/ in it)")
    ap.add_argument("--name", required=True, help="results/<name>.json")
    a = ap.parse_args(argv)
    run = Path(a.run).resolve()
    if not (run / "model.pt").is_file():
        raise SystemExit(f"{run} has no model.pt: the retrain is not finished")
    work = Path(a.work).resolve()
    refs = sorted(work.glob("fold*/ref/renders.zarr"))
    stores = {"default": work / "train" / "renders.zarr", "own": Path(a.retrain_store).resolve()}
    if not refs or not all(s.is_dir() for s in stores.values()):
        raise SystemExit(f"{work} has no fold*/ref/renders.zarr or train/renders.zarr, or {a.retrain_store} is no "
                         f"store: run control.py --phase stores")
    out = Path(a.out_dir).resolve()
    out.mkdir(parents=True, exist_ok=True)
    log = out / "commands.log"
    shipped = evaluations("bundled", out / "bundled", refs, stores, log)
    ours = evaluations(str(run), out / "retrain", refs, stores, log)
    ours["train_views"] = table(evaluate(str(run), out / "retrain" / "eval_train", log, "--suite", "train",
                                         "--store", str(stores["own"]), "--limit", str(TRAIN_VIEWS)))
    effects = {"reference": pooled_effect([(out / "bundled" / f"eval_ref{i}", out / "retrain" / f"eval_ref{i}")
                                           for i in range(len(refs))])}
    for name in stores:
        effects[f"heldout_{name}"] = pooled_effect([(out / "bundled" / f"eval_heldout_{name}",
                                                     out / "retrain" / f"eval_heldout_{name}")])
    fit = json.loads((run / "fit_metrics.json").read_text())
    res = {"question": "is the retrained model better than the shipped one on real materials and svgen held-out "
                       "views, with no column worse beyond its interval?",
           "run": os.path.relpath(run), "retrain_store": os.path.relpath(stores["own"]),
           "references": [os.path.relpath(r) for r in refs], "heldout_views": HELDOUT_VIEWS,
           "train_views": TRAIN_VIEWS, "retrain_fit": {k: fit[k] for k in ("step", "loss_first", "loss_final")},
           "shipped": shipped, "retrain": ours, "effects": effects, "verdict": verdict(effects),
           "spec_stats": {who: spec(out / folder, refs, tuple(f"eval_heldout_{n}" for n in stores))
                          for who, folder in (("shipped", "bundled"), ("retrain", "retrain"))}}
    dest = Path(__file__).parent / "results" / f"{a.name}.json"
    dest.write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps({"effects": {k: {c: [e[c]["control"], e[c]["arm"], e[c]["ci95"]] for c in COLUMNS}
                                  for k, e in effects.items()}, "verdict": res["verdict"]}, indent=1))
    print(f"wrote {dest}")


if __name__ == "__main__":
    main()
