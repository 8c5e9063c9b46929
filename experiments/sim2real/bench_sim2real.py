"""Sim-to-real: a compact model trained on procedural data only, evaluated on real CC0 materials (issue #21).

What it runs, each step the command a user runs (so the figures are those of the project's own commands):

1. training data (skipped with ``--checkpoint``): ``svgen sample`` / ``blend`` / ``render --params params.yaml``, the
   default DVC pipeline's store, into ``WORK/train/`` (a finished store there is reused);
2. training (skipped with ``--checkpoint``): ``svtrain fit --params params.yaml --iterations STEPS`` into
   ``WORK/run`` (a finished run of the same steps there is reused). STEPS: ``--steps``, or ``--budget-s`` times the
   quiet it/s of the model's width in ``--calibration`` (``experiments/train_budget/bench_train_budget.py --calibrate-only``), else
   params.yaml ``train.optim.iterations`` (the ``dvc repro`` model);
3. the reference at each ``--crops`` fraction: ``svgen reference REF WORK/ref_crop<C> --params params.yaml --crop C``
   (imported at the stated physical scale, rendered with the training views; reused when finished);
4. ``svtrain eval --checkpoint RUN --store WORK/ref_crop<C>/renders.zarr`` on each, side by side (a store that is not
   the run's training store: every view, as ``svtrain eval-reference`` does), its eval.md copied to
   ``experiments/sim2real/results/sim2real/crop_<C>.md``; and ``svtrain eval --checkpoint RUN`` on the run's own
   held-out split (``scales.heldout``, ``sim2real/heldout.md``). Baselines: the training split's means, as in every
   eval.

Results: key ``sim_to_real`` of ``experiments/sim2real/results/sim2real.json`` (read, modified, written: other keys,
such as ``sim_to_real_before_fine_grain``, are kept; until #41 the key lived in benchmarks/results/realism.json): per
crop the model's and both baselines' RMSE per column (normal, diffuse, roughness, specular, re-render), and per
column the model's gain over the stronger baseline with its 95 % bootstrap interval over materials; the training run
(steps, store size, how the steps were chosen).

    S=experiments/sim2real/bench_sim2real.py
    python3 $S                      # the dvc repro model (1,200 steps) on a default store
    python3 $S --steps 8760         # the README's budget_30min step count
    python3 $S --budget-s 1800      # steps from the quiet calibration of 2 cores
    python3 $S --checkpoint runs/train   # a run trained elsewhere (e.g. dvc repro)
    python3 $S --steps 2770 --heldout-store OLD/renders.zarr   # + another library's held-out
    python3 $S --steps 2770 --sample-set flat_share=0 --sample-set swap_share=0   # before #22
    python3 $S --steps 2770 --train-set optim.normal_late_loss=rmse   # a training change
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import ROOT, parser, update_results  # noqa: E402

#: this experiment's frozen results (experiments/sim2real/results/)
RESULTS = Path(__file__).resolve().parent / "results"

COLUMNS = ("normal", "diffuse", "roughness", "specular", "rerender")
BASELINES = ("input_as_diffuse", "dataset_mean")
REALISM = RESULTS / "sim2real.json"
TABLES = RESULTS / "sim2real"
DEFAULT_REF = ROOT.parent / "shared" / "materials-cc0"


def sh(cmd: list[str], log: list) -> str:
    """Run a project command, fail loudly; its command line (paths relative to the repository) goes to ``log``."""
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "SVGEN_NO_PROGRESS": "1"})
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({r.returncode}): {r.stderr.strip()[-2000:]}")
    log.append({"cmd": " ".join(_rel(c) for c in cmd), "wall_s": round(time.perf_counter() - t, 1)})
    print(log[-1], flush=True)
    return r.stdout


def _rel(s: str) -> str:
    """An argument as recorded: paths under the repository or its parent relative to them (no absolute paths)."""
    p = Path(s)
    if not p.is_absolute():
        return s
    for base, label in ((ROOT, ""), (ROOT.parent, "../")):
        try:
            return label + str(p.relative_to(base))
        except ValueError:
            pass
    return f"<{p.name}>"


def _done(store: Path) -> bool:
    return (store / "zarr.json").is_file() and not Path(str(store) + ".partial").exists()


def steps_of(a, params: dict) -> tuple[int, str]:
    """Training steps and how they were chosen."""
    if a.steps:
        return a.steps, "--steps"
    width = str(params["train"]["model"]["base_width"])
    if a.budget_s:
        cal = json.loads(Path(a.calibration).read_text())["widths"]
        if width not in cal:
            raise SystemExit(f"{a.calibration} has no calibration of base width {width}")
        rate = float(cal[width]["it_per_s"])
        return max(1, round(a.budget_s * rate)), (f"--budget-s {a.budget_s:g} x {rate:g} it/s (quiet calibration of "
                                                   f"width {width}: {_rel(str(Path(a.calibration).resolve()))})")
    return int(params["train"]["optim"]["iterations"]), "params.yaml train.optim.iterations (the dvc repro model)"


def as_sets(items: list[str]) -> list[str]:
    """``["k=v", ...]`` -> ``["--set", "k=v", ...]`` (svgen/svtrain's repeatable ``--set``)."""
    return [x for kv in items for x in ("--set", kv)]


def train(a, work: Path, log: list) -> tuple[Path, dict]:
    """(run directory, what was trained): the default store and a fit of the chosen steps, each reused if done."""
    import yaml

    params_file = str(ROOT / "params.yaml")
    params = yaml.safe_load(Path(params_file).read_text())
    steps, how = steps_of(a, params)
    d = work / "train"
    d.mkdir(parents=True, exist_ok=True)
    v, b, r = d / "variants.zarr", d / "blends.zarr", d / "renders.zarr"
    sets, train_sets = as_sets(a.sample_set), as_sets(a.train_set)
    for out, cmd in ((v, ["svgen", "sample", str(v), *sets]), (b, ["svgen", "blend", str(v), str(b)]),
                     (r, ["svgen", "render", str(v), str(b), str(r)])):
        if not _done(out):
            sh([*cmd, "--params", params_file], log)
    run = work / f"run_{steps}"
    if not (run / "model.pt").is_file():
        sh(["svtrain", "fit", "--params", params_file, "--store", str(r), "--out", str(run),
            "--iterations", str(steps), *train_sets], log)
    from storage.renders_store import RendersReader

    metrics = json.loads((run / "metrics.json").read_text())
    return run, {"steps": steps, "steps_from": how, "store_views": len(RendersReader(r)),
                 "store": "the default params.yaml store (svgen sample/blend/render --params params.yaml)"
                          + (f", sample with {' '.join(sets)}" if sets else ""),
                 "train_sets": list(a.train_set), "model": params["train"]["model"],
                 "fit_metrics": {k: metrics[k] for k in metrics if isinstance(metrics[k], (int, float))}}


def summarise(res: dict) -> dict:
    """One crop's figures: RMSE per method and column, and per column the gain over the stronger baseline."""
    out = {"views": res["samples"], "svbrdfs": res["paired"]["dataset_mean"]["rerender"]["clusters"],
           "views_note": res["views"]["why"],
           "rmse": {m: {c: round(res[m][c], 5) for c in COLUMNS} for m in ("model", *BASELINES)}, "gain": {}}
    for c in COLUMNS:
        b = min(BASELINES, key=lambda k: res[k][c])
        p = res["paired"][b][c]
        out["gain"][c] = {"baseline": b, "gain": round(p["gain"], 5), "ci95": [round(x, 5) for x in p["ci95"]],
                          "views_better": round(p["views_better"], 3), "beats_beyond_noise": p["ci95"][0] > 0}
    return out


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--reference", default=os.environ.get("SVGEN_REFERENCE_DIR") or str(DEFAULT_REF),
                    help="real material folders (default: SVGEN_REFERENCE_DIR, else ../shared/materials-cc0)")
    ap.add_argument("--crops", type=float, nargs="+", default=[1.0, 0.5],
                    help="reference crop fractions (1: whole tiles; 0.5: the centre half-width window)")
    ap.add_argument("--checkpoint", default=None, help="evaluate this run instead of training one")
    ap.add_argument("--steps", type=int, default=0, help="training steps (default: params.yaml's)")
    ap.add_argument("--budget-s", type=float, default=0.0, help="training budget in quiet wall seconds -> steps")
    ap.add_argument("--calibration", default=str(ROOT / "benchmarks" / "results" / "train_budget_calibration.json"),
                    help="bench_train_budget.py --calibrate-only output: it/s per base width")
    ap.add_argument("--work", default=str(ROOT / "runs" / "sim2real"), help="scratch folder (stores, runs)")
    ap.add_argument("--out", default=str(REALISM), help="results JSON (read-modify-write of key sim_to_real)")
    ap.add_argument("--tables", default=str(TABLES), help="folder of the eval.md tables")
    ap.add_argument("--sample-set", action="append", default=[], metavar="KEY=VALUE",
                    help="a sample setting for the training store (svgen sample --set; repeatable), e.g. the "
                         "library before a change as the control of an equal-steps comparison")
    ap.add_argument("--train-set", action="append", default=[], metavar="KEY=VALUE",
                    help="a training setting (svtrain fit --set; repeatable), e.g. optim.normal_late_loss=rmse")
    ap.add_argument("--heldout-store", default=None,
                    help="also evaluate the held-out split of this renders store (scales.heldout_other): the same "
                         "views as a run trained on another library (e.g. data/renders.zarr of the library before)")
    a = ap.parse_args(argv)
    ref = Path(a.reference)
    if not ref.is_dir():
        raise SystemExit(f"no reference folder at {ref} (--reference or SVGEN_REFERENCE_DIR)")
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    log: list = []
    t0 = time.perf_counter()
    if a.checkpoint:
        from train.checkpoint import load

        state = load(a.checkpoint)  # a run directory (model.pt, else checkpoint.pt) or a checkpoint file
        conf = state["config"]
        run = Path(a.checkpoint)
        trained = {"checkpoint": _rel(str(run.resolve())), "steps": int(state.get("step", 0)),
                   "planned_iterations": conf["optim"]["iterations"], "steps_from": "--checkpoint",
                   "model": conf["model"], "final": state.get("step") == conf["optim"]["iterations"]}
    else:
        run, trained = train(a, work, log)
    params_file = str(ROOT / "params.yaml")
    scales, tables = {}, Path(a.tables)
    tables.mkdir(parents=True, exist_ok=True)
    for crop in a.crops:  # the reference stores first (one at a time: each import/render uses the workers)
        rd = work / f"ref_crop{crop:g}"
        if not _done(rd / "renders.zarr"):
            shutil.rmtree(rd, ignore_errors=True)
            sh(["svgen", "reference", str(ref), str(rd), "--params", params_file, "--crop", str(crop)], log)

    def evaluate(crop: float) -> dict:  # one process per crop, side by side (each is a single-process eval)
        ev = work / f"eval_{run.stem}_crop{crop:g}"
        sh(["svtrain", "eval", "--checkpoint", str(run), "--store",  # a foreign store: every view (eval.md says so)
            str(work / f"ref_crop{crop:g}" / "renders.zarr"), "--out", str(ev)], log)
        return json.loads((ev / "eval.json").read_text())

    with ThreadPoolExecutor(len(a.crops)) as pool:
        results = dict(zip(a.crops, pool.map(evaluate, a.crops)))
    for crop, res in results.items():
        ev = work / f"eval_{run.stem}_crop{crop:g}"
        scales[f"crop_{crop:g}"] = {"crop": crop, **summarise(res)}
        (tables / f"crop_{crop:g}.md").write_text(
            f"# Sim-to-real: {trained.get('steps')} steps, reference crop {crop:g}\n\n"
            f"{trained.get('steps_from')}; reference {ref.name} imported at crop {crop:g} and rendered "
            f"with params.yaml's render section.\n\n{(ev / 'eval.md').read_text()}")
    # beside the reference: the run's own held-out split (materials of the training library it never saw), so one
    # file says how the same model does on svgen's held-out and on real materials
    ev = work / f"eval_{run.stem}_heldout"
    sh(["svtrain", "eval", "--checkpoint", str(run), "--out", str(ev)], log)
    scales["heldout"] = {"crop": None, **summarise(json.loads((ev / "eval.json").read_text()))}
    (tables / "heldout.md").write_text(f"# Held-out: {trained.get('steps')} steps\n\n{trained.get('steps_from')}; "
                                       f"the training store's held-out split.\n\n{(ev / 'eval.md').read_text()}")
    if a.heldout_store:  # the held-out split of another store: materials this run never saw (split by preset)
        ev = work / f"eval_{run.stem}_heldout_other"
        sh(["svtrain", "eval", "--checkpoint", str(run), "--store", a.heldout_store, "--suite", "heldout",
            "--out", str(ev)], log)
        scales["heldout_other"] = {"crop": None, "store": _rel(str(Path(a.heldout_store).resolve())),
                                   **summarise(json.loads((ev / "eval.json").read_text()))}
    n_ref = sum(1 for _ in ref.iterdir() if _.is_dir())
    block = {"benchmark": "bench_sim2real", "reference": {"folder": ref.name, "material_folders": n_ref},
             "training": trained,
             "scales": scales, "commands": log, "total_wall_s": round(time.perf_counter() - t0, 1),
             "load1_end": round(os.getloadavg()[0], 2), "tables": _rel(str(tables.resolve()))}
    update_results(Path(a.out), "sim_to_real", block, a.note)
    print(json.dumps(scales, indent=1))


if __name__ == "__main__":
    main()
