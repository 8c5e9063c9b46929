"""The real-data control of issue #39: does putting real materials into the training data close the real-shape gap?

Arms, all trained from scratch with the same seed, steps and config (``params.yaml``'s ``train`` section):

- ``control``: the default library's store (``svgen sample/blend/render --params params.yaml``);
- ``fold<i>``, one per fold of the reference library (:func:`svcore.split.material_folds`): the same store plus the
  materials *outside* fold ``i``, imported (``svgen import``), perturbed ``--per-material`` times each
  (``svgen sample --from … --only-from``) and rendered into one store with the library's variants and blends.

Every arm is evaluated on the reference materials of the fold(s) it never trained on (``svgen reference`` of that
fold's folders at ``--crop``; :func:`svcore.split.check_unseen` refuses a leak), on its own held-out svgen views and
on 400 of its own training views (``svtrain eval --suite train``: an arm that cannot fit what it saw cannot show an
effect). The effect of real data on each column is control minus arm on the same reference views, pooled over the
folds, with a 95 % bootstrap interval over materials (:func:`train.evaluate.paired`).

    python3 experiments/real_shape/control.py --work runs/rs --steps 4000 --folds 2

Each step is the command a user runs; a finished store or run under ``--work`` is reused (rerun to resume).
Results: ``experiments/real_shape/results/control_<steps>.json``.
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from svcore.split import check_unseen, material_folds  # noqa: E402

COLUMNS = ("rerender", "normal", "diffuse", "roughness", "specular")
PARAMS = str(ROOT / "params.yaml")
PREFIX = "imported/"  # the name `svgen import` gives a material folder


def sh(cmd: list[str], log: Path) -> None:
    """Run a project command; its output goes to ``log``; a failure stops the experiment with its tail."""
    t = time.perf_counter()
    with open(log, "a") as f:
        f.write("$ " + " ".join(cmd) + "\n")
        f.flush()
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, env={**os.environ, "SVGEN_NO_PROGRESS": "1"})
    if r.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed ({r.returncode}); see {log}")
    print(f"{time.perf_counter() - t:7.1f} s  {' '.join(cmd)}", flush=True)


def done(store: Path) -> bool:
    return (store / "zarr.json").is_file() and not Path(str(store) + ".partial").exists()


def reference_folders(ref: Path) -> dict[str, Path]:
    """Material name as imported -> its folder, for every material folder of the reference library."""
    return {PREFIX + p.name: p for p in sorted(ref.iterdir()) if p.is_dir()}


def build_stores(a, work: Path, log: Path) -> list[list[str]]:
    """The default store, and per fold its training store and its evaluation reference. Returns the folds."""
    tr = work / "train"
    tr.mkdir(parents=True, exist_ok=True)
    v, b, r = tr / "variants.zarr", tr / "blends.zarr", tr / "renders.zarr"
    for out, cmd in ((v, ["svgen", "sample", str(v)]), (b, ["svgen", "blend", str(v), str(b)]),
                     (r, ["svgen", "render", str(v), str(b), str(r)])):
        if not done(out):
            sh([*cmd, "--params", PARAMS], log)
    folders = reference_folders(Path(a.reference))
    folds = material_folds(list(folders), a.folds, a.fold_seed)
    for i, fold in enumerate(folds):
        d = work / f"fold{i}"
        d.mkdir(exist_ok=True)
        train_names = [n for n in folders if n not in fold]
        imp, var, ren, ref = d / "real_import.zarr", d / "real_variants.zarr", d / "renders.zarr", d / "ref"
        if not done(imp):
            sh(["svgen", "import", *(str(folders[n]) for n in train_names), str(imp), "--params", PARAMS], log)
        if not done(var):
            sh(["svgen", "sample", str(var), "--from", str(imp), "--only-from", "--per-material",
                str(a.per_material), "--params", PARAMS], log)
        if not done(ren):
            sh(["svgen", "render", str(v), str(b), str(var), str(ren), "--params", PARAMS], log)
        if not done(ref / "renders.zarr"):
            sh(["svgen", "reference", *(str(folders[n]) for n in fold), str(ref), "--params", PARAMS,
                "--crop", str(a.crop)], log)
    return folds


def arm_stores(items: list[str], known) -> dict[str, Path]:
    """``--arm-store NAME=STORE`` items -> {name: store}, NAME one of ``known`` (the data arms) and STORE existing."""
    out = {}
    for item in items:
        name, _, path = item.partition("=")
        if name not in known or not Path(path).is_dir():
            raise SystemExit(f"--arm-store {item}: want NAME=STORE with NAME one of {', '.join(known)} and an "
                             f"existing store")
        out[name] = Path(path).resolve()
    return out


def store_materials(store: Path) -> list[tuple[str, ...]]:
    from storage.renders_store import RendersReader

    return RendersReader(str(store)).source_presets()


def side_by_side(jobs: dict[str, list[str]], logs: Path, threads: int) -> None:
    """Run ``svtrain fit`` commands at once, one log each (``logs/fit_<name>.log``), ``threads`` torch threads each;
    a failure stops the experiment."""
    procs = []
    for name, cmd in jobs.items():
        f = open(logs / f"fit_{name}.log", "a")
        f.write("$ " + " ".join(cmd) + "\n")
        f.flush()
        procs.append((name, subprocess.Popen(cmd, stdout=f, stderr=subprocess.STDOUT,
                                             env={**os.environ, "SVGEN_NO_PROGRESS": "1",
                                                  "OMP_NUM_THREADS": str(threads)}), f))
    for name, p, f in procs:
        if p.wait():
            raise SystemExit(f"fit of {name} failed; see {logs / f'fit_{name}.log'}")
        f.close()
        print(f"fit {name} done", flush=True)


def fit_all(a, work: Path, runs: dict[str, Path], log: Path) -> None:
    """Train every arm side by side, one torch thread each (same threads for all: same arithmetic)."""
    side_by_side({name: ["svtrain", "fit", "--params", PARAMS, "--store", str(store), "--out",
                         str(work / "runs" / name), "--iterations", str(a.steps), "--workers", "0",
                         "--set", f"optim.threads={a.threads}", "--set", f"optim.lr={a.lr}", *a.train_set]
                  for name, store in runs.items() if not (work / "runs" / name / "model.pt").is_file()},
                 work, a.threads)


def evaluate(run: Path, out: Path, log: Path, *extra: str) -> dict:
    if not (out / "eval.json").is_file():
        sh(["svtrain", "eval", "--checkpoint", str(run), "--out", str(out), *extra], log)
    return json.loads((out / "eval.json").read_text())


def per_view(folder: Path) -> dict[int, dict]:
    with open(folder / "per_view.csv") as f:
        return {int(r["view"]): {"svbrdf": int(r["svbrdf"]), **{c: float(r[c]) for c in COLUMNS}}
                for r in csv.DictReader(f)}


def pooled_effect(pairs: list[tuple[Path, Path]]) -> dict:
    """Per column: control and arm mean RMSE over the pooled views of every fold, and the paired gain
    (control - arm; positive: real data helps), its 95 % interval resampling whole materials."""
    from train.evaluate import paired

    ctl, arm, clusters = {c: [] for c in COLUMNS}, {c: [] for c in COLUMNS}, []
    for k, (c_dir, a_dir) in enumerate(pairs):
        x, y = per_view(c_dir), per_view(a_dir)
        if sorted(x) != sorted(y):
            raise SystemExit(f"{c_dir} and {a_dir} did not evaluate the same views")
        for v in sorted(x):
            clusters.append(k * 1_000_000 + x[v]["svbrdf"])
            for c in COLUMNS:
                ctl[c].append(x[v][c])
                arm[c].append(y[v][c])
    out = {"views": len(clusters), "materials": len(set(clusters))}
    for c in COLUMNS:
        xc, yc = np.array(ctl[c]), np.array(arm[c])
        p = paired(yc, xc, np.array(clusters), seed=0)
        out[c] = {"control": round(float(xc.mean()), 5), "arm": round(float(yc.mean()), 5),
                  "gain": round(p["gain"], 5), "ci95": [round(v, 5) for v in p["ci95"]],
                  "beyond_noise": "better" if p["ci95"][0] > 0 else "worse" if p["ci95"][1] < 0 else "no"}
    return out


def table(res: dict) -> dict:
    """The figures of one eval.json: the model's RMSE per column and its normal RMSE over the flat map's."""
    m, flat = res["model"], res["dataset_mean"]
    return {"model": {c: round(m[c], 5) for c in COLUMNS}, "flat_normal": round(flat["normal"], 5),
            "normal_over_flat": round(m["normal"] / flat["normal"], 4), "views": res["samples"]}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--work", default=str(ROOT / "runs" / "real_shape"), help="scratch folder (stores, runs)")
    ap.add_argument("--reference", default=str(ROOT.parent / "shared" / "materials-cc0"))
    ap.add_argument("--folds", type=int, default=2)
    ap.add_argument("--fold-seed", type=int, default=0)
    ap.add_argument("--per-material", type=int, default=15, help="perturbed variants per real training material")
    ap.add_argument("--crop", type=float, default=1.0, help="physical scale of the evaluated reference")
    ap.add_argument("--steps", type=int, required=True)
    ap.add_argument("--lr", type=float, default=5e-4,
                    help="Adam learning rate of every arm (params.yaml's 1e-3 diverged at step 700 in a 1-thread "
                         "control: loss 1.4 -> 54, normals saturated)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads per run (every arm the same)")
    ap.add_argument("--train-set", action="append", default=[], help="extra `svtrain fit` arguments (every arm)")
    ap.add_argument("--phase", choices=("all", "stores", "fit", "eval"), default="all",
                    help="stop after the stores, or only fit, or only evaluate finished runs (all: everything)")
    ap.add_argument("--arms", nargs="*", default=None, help="fit only these arms (control, fold0, ...)")
    ap.add_argument("--net-arm", action="append", default=[], metavar="NAME",
                    help="a run WORK/runs/NAME trained on the control's store with another model or loss (started "
                         "by hand with the control's command plus its --set): evaluated on every fold's reference "
                         "and on the held-out views, paired with the control")
    ap.add_argument("--out", default=None, help="results JSON (default results/control_<steps>.json here)")
    a = ap.parse_args(argv)
    work = Path(a.work).resolve()
    work.mkdir(parents=True, exist_ok=True)
    log = work / "commands.log"
    folds = build_stores(a, work, log)
    for i, fold in enumerate(folds):  # the guarantee the design rests on, checked on the stores as written
        check_unseen(store_materials(work / f"fold{i}" / "renders.zarr"), fold)
    runs = {"control": work / "train" / "renders.zarr",
            **{f"fold{i}": work / f"fold{i}" / "renders.zarr" for i in range(len(folds))}}
    if a.phase == "stores":
        return
    if a.phase in ("all", "fit"):
        fit_all(a, work, {k: v for k, v in runs.items() if a.arms is None or k in a.arms}, log)
        if a.phase == "fit":
            return
    res = {"question": "real materials in the training data (folds over the reference) against the svgen-only "
                       "library, from scratch, same seed, steps and config",
           "steps": a.steps, "folds": folds, "per_material": a.per_material, "crop": a.crop,
           "threads_per_run": a.threads, "lr": a.lr, "train_set": a.train_set,
           "runs": {}, "effect_real_data": {}}
    pairs = []
    for name in runs:
        run = work / "runs" / name
        fit = {**json.loads((run / "metrics.json").read_text()),  # timings: timing.json since 390b66e
               **(json.loads((run / "timing.json").read_text()) if (run / "timing.json").is_file() else {})}
        r = {"fit_wall_s": fit.get("train_wall_s"), "fit_cpu_s": fit.get("train_cpu_s"), "train_views": table(evaluate(run, run / "eval_train", log, "--suite", "train")),
             "heldout": table(evaluate(run, run / "eval_heldout", log))}
        for i in range(len(folds)):
            if name in ("control", f"fold{i}"):
                r[f"reference_fold{i}"] = table(evaluate(run, run / f"eval_ref{i}", log, "--store",
                                                         str(work / f"fold{i}" / "ref" / "renders.zarr")))
        res["runs"][name] = r
    for i in range(len(folds)):
        pairs.append((work / "runs" / "control" / f"eval_ref{i}", work / "runs" / f"fold{i}" / f"eval_ref{i}"))
    res["effect_real_data"] = pooled_effect(pairs)
    res["net_arms"] = {}
    ctl = work / "runs" / "control"
    for name in a.net_arm:
        run = work / "runs" / name
        fit = {**json.loads((run / "metrics.json").read_text()),  # timings: timing.json since 390b66e
               **(json.loads((run / "timing.json").read_text()) if (run / "timing.json").is_file() else {})}
        r = {"model": yaml.safe_load((run / "config.yaml").read_text())["train"]["model"], "fit_wall_s": fit.get("train_wall_s"),
             "fit_cpu_s": fit.get("train_cpu_s"),
             "train_views": table(evaluate(run, run / "eval_train", log, "--suite", "train")),
             "heldout": table(evaluate(run, run / "eval_heldout", log))}
        for i in range(len(folds)):
            r[f"reference_fold{i}"] = table(evaluate(run, run / f"eval_ref{i}", log, "--store",
                                                     str(work / f"fold{i}" / "ref" / "renders.zarr")))
        r["effect_reference"] = pooled_effect([(ctl / f"eval_ref{i}", run / f"eval_ref{i}")
                                               for i in range(len(folds))])
        r["effect_heldout"] = pooled_effect([(ctl / "eval_heldout", run / "eval_heldout")])
        res["net_arms"][name] = r
    out = Path(a.out) if a.out else Path(__file__).parent / "results" / f"control_{a.steps}.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps(res["effect_real_data"], indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
