"""The paper's three claims as an experiment grid, run with DVC's own experiment machinery (issue #11).

Factors (the paper's choice first): the global-feature track (on / off), the loss (today's default: rendering +
the normal term / rendering only, the paper / L1 on the maps), the training data (variants + blends / variants
only). ``--design ofat`` varies one factor at a time from the defaults (5 cells), ``--design full`` crosses them
(12 cells); each cell trains ``--seeds`` seeds on one fixed CPU budget.

    python3 benchmarks/ablation.py --design ofat --seeds 0 1 --cpu-budget 150 --jobs 1

1. calibrates the steps of each cell for ``--cpu-budget`` CPU seconds of training: two short ``svtrain fit`` runs per
   cost class (model x loss; the data filter costs nothing), CPU seconds per step from the difference of the two
   runs' training clocks (startup and torch.compile cancel) -> ``--calibration`` JSON;
2. queues every cell x seed with ``dvc exp run --queue -n NAME -S train.… -s fit eval eval_stress eval_extra``
   (the data stages are unchanged, so their outputs come from DVC's cache and run cache, not a rerun);
3. runs the queue (``dvc queue start -j N``) and waits for it;
4. reads ``dvc exp show --json`` (params, metrics, the experiment commits) and, from each experiment's commit, the
   held-out curve (runs/train/heldout.csv, by step; its CPU axis from the calibration: :func:`cpu_axis`) and the
   per-view errors (runs/eval*/per_view.csv);
5. computes each claim's effect per column and suite (benchmarks/ablation_effects.py) -> ``--out`` (ablation.json)
   and the effects table beside it (ablation.md).

Every cell uses one held-out split (``train.data.split_seed``, fixed), whatever its training seed, so all cells are
evaluated on the same views; ``--steps N`` skips the calibration (tests, or a fixed step budget).
"""
from __future__ import annotations

import csv
import io
import itertools
import json
import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ablation_effects import BOOT_SEED, RESAMPLES, effect, markdown
from harness import RESULTS, ROOT, parser, write_results

#: factor -> level -> params.yaml overrides under ``train.`` (the first level is the paper's choice / the default).
FACTORS: dict[str, dict[str, dict[str, object]]] = {
    "global": {"on": {"model.global_track": True}, "off": {"model.global_track": False}},
    # the default level keeps params.yaml's loss (the normal terms and the map L1 weight: the compact preset's), so
    # the grid's default cell is the default model whatever its terms are; the other two turn every normal term off
    # (the late one included, #39) so that each is the loss it names
    "loss": {"default": {"optim.render_weight": 1.0},
             "render": {"optim.render_weight": 1.0, "optim.map_l1": 0.0, "optim.normal_l2": 0.0,
                        "optim.normal_late_loss": None},
             "l1": {"optim.render_weight": 0.0, "optim.map_l1": 1.0, "optim.normal_l2": 0.0,
                    "optim.normal_late_loss": None}},
    "data": {"blends": {"data.blends": True}, "variants": {"data.blends": False}},
    # not one of the paper's claims: #10's open question (is the compact width 8 too narrow for 2 cores?) asked at
    # the grid's budget with its seeds; width 16 as experiments/train_budget swept it (max_width = 8 x base)
    "width": {"8": {"model.base_width": 8, "model.max_width": 64},
              "16": {"model.base_width": 16, "model.max_width": 128}},
}
DEFAULTS = {"global": "on", "loss": "default", "data": "blends", "width": "8"}
#: claim -> (factor, the paper's choice, the alternative): what each effect compares.
CLAIMS = {"global track": ("global", "on", "off"),
          "rendering loss vs L1 on maps": ("loss", "render", "l1"),
          "normal term": ("loss", "default", "render"),
          "blends": ("data", "blends", "variants"),
          "width 8 vs 16 (#10)": ("width", "8", "16")}
#: the stages that depend on training (the grid never reruns render).
TARGETS = ("fit", "eval", "eval_stress", "eval_extra")
#: suite -> (the stage output holding its per-view errors) read from every experiment's commit.
PER_VIEW = {"heldout": "runs/eval/per_view.csv", "stress": "runs/eval_stress/per_view.csv"}
HELDOUT_CSV = "runs/train/heldout.csv"
FIT_METRICS = "runs/train/metrics.json"
EXTRA_STORES = "runs/eval_extra/stores/stores.json"
COLUMNS = ("rerender", "normal", "diffuse", "roughness", "specular")
ENV = {**os.environ, "SVGEN_NO_PROGRESS": "1"}


def cells(design: str) -> dict[str, dict[str, str]]:
    """Cell name -> {factor: level}. ofat: the defaults and each other level of one factor; full: every
    combination."""
    if design == "ofat":
        out = {"default": dict(DEFAULTS)}
        for f, levels in FACTORS.items():
            for lv in levels:
                if lv != DEFAULTS[f]:
                    out[f"{f}-{lv}"] = {**DEFAULTS, f: lv}
        return out
    if design == "full":
        return {"-".join(combo): dict(zip(FACTORS, combo)) for combo in itertools.product(*FACTORS.values())}
    raise SystemExit(f"unknown design {design!r}: ofat or full")


def overrides(arms: dict[str, str]) -> dict[str, object]:
    """The train config overrides (keys without ``train.``) of a cell."""
    out: dict[str, object] = {}
    for f, lv in arms.items():
        out.update(FACTORS[f][lv])
    return out


def yaml_value(v) -> str:
    return "true" if v is True else "false" if v is False else "null" if v is None else str(v)


def sh(cmd: list[str], cwd: Path, check: bool = True) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, cwd=cwd, env=ENV, capture_output=True, text=True)
    if check and r.returncode:
        raise SystemExit(f"{shlex.join(cmd)} failed ({r.returncode}): {(r.stderr or r.stdout).strip()[-2000:]}")
    return r


# --- 1. calibration ---------------------------------------------------------------------------------------------

def cost_key(arms: dict[str, str]) -> str:
    """Cells with the same model and loss cost the same per step (the data filter only picks other samples)."""
    return f"{arms['global']}-{arms['loss']}-w{arms.get('width', DEFAULTS['width'])}"


def calibrate(project: Path, grid: dict, store: str, steps: tuple[int, int], extra: list[str]) -> dict:
    """CPU and wall seconds per training step of each cost class, from two ``svtrain fit`` runs of ``steps``."""
    out = {}
    for key, arms in {cost_key(a): a for a in grid.values()}.items():
        runs = []
        # a first, discarded run warms torch.compile's disk cache: otherwise the shorter run pays the cold compile
        # and the difference between the two runs is noise, even negative (seen on a quiet machine)
        for n in (steps[0], *steps):
            with tempfile.TemporaryDirectory(prefix="ablation-calib-") as tmp:
                cmd = ["svtrain", "fit", "--params", "params.yaml", "--store", store, "--out", tmp, "--no-resume",
                       "--iterations", str(n), "--set", "optim.eval_every=0", *extra,
                       *itertools.chain.from_iterable(("--set", f"{k}={yaml_value(v)}")
                                                      for k, v in overrides(arms).items())]
                sh(cmd, project)
                m = json.loads((Path(tmp) / "timing.json").read_text())  # the run's clock (train/timing.py)
            runs.append({"steps": n, "train_cpu_s": m["train_cpu_s"], "train_wall_s": m["train_wall_s"],
                         "command": shlex.join(cmd)})
        warmup, runs = runs[0], runs[1:]
        d = steps[1] - steps[0]
        per_step = (runs[1]["train_cpu_s"] - runs[0]["train_cpu_s"]) / d if d > 0 else 0.0
        # a noisy difference (a loaded machine, too few steps) must not turn into millions of steps
        floor = runs[1]["train_cpu_s"] / steps[1] / 4
        if per_step < floor:
            raise SystemExit(f"calibration of {key} is noise ({per_step:.4f} CPU-s/step from {steps} steps, below a "
                             f"quarter of the mean {4 * floor:.4f}): use larger --calib-steps or a quieter machine")
        out[key] = {"cpu_s_per_step": per_step,
                    "wall_s_per_step": (runs[1]["train_wall_s"] - runs[0]["train_wall_s"]) / d,
                    "runs": runs}
        # what the training clock counts besides the steps (torch.compile of the loss renderer in the first step, a
        # few seconds once inductor's disk cache holds it): the curves' CPU axis includes it, the step budget not
        out[key]["overhead_cpu_s"] = runs[0]["train_cpu_s"] - steps[0] * out[key]["cpu_s_per_step"]
        out[key]["warmup_run"] = warmup
        print(f"calibrated {key}: {out[key]['cpu_s_per_step']:.3f} CPU-s/step", file=sys.stderr)
    return out


# --- 2-3. queue and run -----------------------------------------------------------------------------------------

def queue(project: Path, name: str, sets: dict[str, object], targets=TARGETS) -> str:
    """``dvc exp run --queue`` one experiment; returns the command."""
    cmd = ["dvc", "exp", "run", "--queue", "-n", name,
           *itertools.chain.from_iterable(("-S", f"train.{k}={yaml_value(v)}") for k, v in sets.items()), *targets]
    sh(cmd, project)
    return shlex.join(cmd)


def run_queue(project: Path, jobs: int, poll_s: float = 2.0) -> dict[str, str]:
    """``dvc queue start -j jobs`` and wait until nothing is queued or running; returns {name: final status}."""
    sh(["dvc", "queue", "start", "-j", str(jobs)], project)
    while True:
        status = queue_status(project)
        if status and not any(s in ("Queued", "Running") for s in status.values()):
            return status
        time.sleep(poll_s)


def queue_status(project: Path) -> dict[str, str]:
    """{experiment name: Queued | Running | Success | Failed} from ``dvc queue status``."""
    out = {}
    for line in sh(["dvc", "queue", "status"], project).stdout.splitlines()[1:]:
        parts = line.split()
        if len(parts) >= 3 and parts[-1] in ("Queued", "Running", "Success", "Failed"):
            out[parts[1]] = parts[-1]
    return out


# --- 4. read back -----------------------------------------------------------------------------------------------

def exp_show(project: Path) -> dict[str, dict]:
    """{experiment name: {"rev", "params" (params.yaml), "metrics" {path: values}}} from ``dvc exp show --json``."""
    rows = json.loads(sh(["dvc", "exp", "show", "--json"], project).stdout)
    out = {}
    for base in rows:
        for exp in base.get("experiments") or []:
            for rev in exp.get("revs") or []:
                data = rev.get("data") or {}
                name = rev.get("name") or exp.get("name")
                params = ((data.get("params") or {}).get("params.yaml") or {}).get("data") or {}
                metrics = {p: (v or {}).get("data") for p, v in (data.get("metrics") or {}).items()}
                out[name] = {"rev": data.get("rev") or rev.get("rev"), "params": params, "metrics": metrics}
    return out


def exp_file(project: Path, rev: str, path: str) -> str | None:
    """A stage output of an experiment's commit, from DVC's cache (the run outputs are cached: runs/ is not in git);
    None when that experiment has no such output."""
    import dvc.api

    try:
        return dvc.api.read(path, repo=str(project), rev=rev)
    except Exception:  # noqa: BLE001 -- dvc raises several types for "not there" (no stage, not in cache)
        return None


def read_csv(text: str | None) -> list[dict]:
    if not text:
        return []
    return [{k: (v if k == "group" else float(v)) for k, v in row.items()} for row in csv.DictReader(io.StringIO(text))]


def per_view_of(project: Path, rev: str) -> dict[str, list[dict]]:
    """suite -> per-view rows of one experiment (held-out, stress and every extra store)."""
    paths = dict(PER_VIEW)
    stores = exp_file(project, rev, EXTRA_STORES)
    for name in json.loads(stores) if stores else {}:
        paths[f"extra:{name}"] = f"runs/eval_extra/stores/{name}/per_view.csv"
    return {s: rows for s, p in paths.items() if (rows := read_csv(exp_file(project, rev, p)))}


# --- 5. effects -------------------------------------------------------------------------------------------------

def pairs_of(grid: dict, factor: str, choice: str, alt: str) -> list[tuple[str, str]]:
    """(choice cell, alternative cell) pairs that differ only in ``factor``."""
    out = []
    for a, arms_a in grid.items():
        if arms_a[factor] != choice:
            continue
        for b, arms_b in grid.items():
            if arms_b == {**arms_a, factor: alt}:
                out.append((a, b))
    return out


def effects(grid: dict, runs: dict) -> dict:
    """claim -> {"factor", "choice", "alternative", "pairs", "suites": {suite: {column: effect}}}; errors of paired
    cells are stacked (every pair's seeds) so a full design averages the claim over the other factors."""
    out = {}
    for claim, (factor, choice, alt) in CLAIMS.items():
        pairs = [p for p in pairs_of(grid, factor, choice, alt) if runs.get(p[0]) and runs.get(p[1])]
        if not pairs:
            continue
        suites = {}
        for suite in sorted({s for p in pairs for c in p for r in runs[c].values() for s in r["per_view"]}):
            cols = {}
            for col in COLUMNS:
                a, b, cl = [], [], None
                for ca, cb in pairs:
                    ea = [r["per_view"][suite] for r in runs[ca].values() if suite in r["per_view"]]
                    eb = [r["per_view"][suite] for r in runs[cb].values() if suite in r["per_view"]]
                    if not ea or not eb:
                        continue
                    ids = [row["svbrdf"] for row in ea[0]]
                    a += [[row[col] for row in rows] for rows in ea]
                    b += [[row[col] for row in rows] for rows in eb]
                    cl = ids
                if a and b:
                    cols[col] = effect(np.array(a), np.array(b), np.array(cl))
            suites[suite] = cols
        out[claim] = {"factor": factor, "choice": choice, "alternative": alt, "pairs": pairs, "suites": suites}
    return out


def views_of(per_view: dict) -> dict[str, list[int]]:
    """suite -> the evaluated view indices (identical across cells when the split is)."""
    return {s: [int(r["view"]) for r in rows] for s, rows in per_view.items()}


def cpu_axis(rows: list[dict], cost: dict | None) -> list[dict]:
    """The held-out curve's rows with ``cpu_s``, the training CPU seconds at each row's step from the calibration
    of the cell's cost class (``cost``: its ``overhead_cpu_s`` + step x ``cpu_s_per_step``); unchanged without one.

    An experiment's own clock is not among its outputs: DVC hashes every declared output, and a clock in one would
    change dvc.lock on every run (issue #40; train/timing.py). The calibrated cost is also what set each cell's
    steps, so the curves compare the arms at the training cost their budget was computed from."""
    if not cost:
        return rows
    return [{**r, "cpu_s": cost.get("overhead_cpu_s", 0.0) + r["step"] * cost["cpu_s_per_step"]} for r in rows]


def collect(project: Path, grid: dict, names: dict, commands: dict, statuses: dict,
            calib: dict | None = None) -> dict:
    """cell -> seed -> what one experiment gave (``calib``: the calibration, whose costs give the curves their
    CPU axis, :func:`cpu_axis`)."""
    shown = exp_show(project)
    runs: dict[str, dict[str, dict]] = {}
    for (cell, seed), name in names.items():
        exp = shown.get(name)
        if exp is None:
            runs.setdefault(cell, {})
            continue
        rev = exp["rev"]
        fit_metrics = json.loads(exp_file(project, rev, FIT_METRICS) or "{}")
        pv = per_view_of(project, rev)
        cost = (calib or {}).get(cost_key(grid[cell]))
        runs.setdefault(cell, {})[str(seed)] = {
            "exp": name, "rev": rev, "status": statuses.get(name), "command": commands[(cell, seed)],
            "train_params": exp["params"].get("train"), "metrics": exp["metrics"],
            "steps": fit_metrics.get("step"),
            "train_cpu_s": cpu_axis([{"step": fit_metrics["step"]}], cost)[0].get("cpu_s")
            if "step" in fit_metrics else None,
            "heldout_curve": cpu_axis(read_csv(exp_file(project, rev, HELDOUT_CSV)), cost),
            "views": views_of(pv), "per_view": {s: [{k: r[k] for k in ("svbrdf", *COLUMNS)} for r in rows]
                                                for s, rows in pv.items()}}
    return runs


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--design", choices=("ofat", "full"), default="ofat")
    ap.add_argument("--cells", nargs="+", default=None, help="only these cells of the design (default: all)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1], help="training seeds (optim.seed) per cell")
    ap.add_argument("--cpu-budget", type=float, default=150.0, help="CPU seconds of training per cell and seed")
    ap.add_argument("--steps", type=int, default=None, help="fixed steps for every cell (skips the calibration)")
    ap.add_argument("--calib-steps", type=int, nargs=2, default=(10, 50),
                    help="the two calibration runs' steps (the second larger)")
    ap.add_argument("--points", type=int, default=8, help="held-out evaluations along each fit (optim.eval_every)")
    ap.add_argument("--split-seed", type=int, default=0, help="train.data.split_seed of every cell")
    ap.add_argument("--store", default="data/renders.zarr", help="the fit stage's store (calibration runs)")
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                    help="a train config override for every cell and the calibration (key without 'train.')")
    ap.add_argument("--targets", nargs="+", default=list(TARGETS), help="the stages each experiment runs")
    ap.add_argument("--jobs", type=int, default=1, help="experiments run at once (dvc queue start -j)")
    ap.add_argument("--tag", default=time.strftime("abl%m%d%H%M"), help="experiment name prefix")
    ap.add_argument("--project", type=Path, default=ROOT, help="the DVC project (a git repository)")
    ap.add_argument("--out", type=Path, default=RESULTS / "ablation.json")
    ap.add_argument("--calibration", type=Path, default=RESULTS / "ablation_calibration.json")
    a = ap.parse_args(argv)
    project = a.project.resolve()
    grid = cells(a.design)
    if a.cells:
        unknown = set(a.cells) - set(grid)
        if unknown:
            raise SystemExit(f"unknown cells {sorted(unknown)}; the {a.design} design has {sorted(grid)}")
        grid = {c: grid[c] for c in a.cells}
    common = dict(s.split("=", 1) for s in a.sets)
    common_typed = {k: _yaml(v) for k, v in common.items()}

    if a.steps is None:
        calib = calibrate(project, grid, a.store, tuple(a.calib_steps), [x for s in a.sets for x in ("--set", s)])
        write_results(a.calibration, {"cpu_budget_s": a.cpu_budget, "calib_steps": list(a.calib_steps),
                                      "per_step": calib}, a.note)
        steps = {c: max(1, int(a.cpu_budget / calib[cost_key(arms)]["cpu_s_per_step"])) for c, arms in grid.items()}
    else:
        calib, steps = None, {c: a.steps for c in grid}

    names, commands = {}, {}
    for cell, arms in grid.items():
        for seed in a.seeds:
            name = f"{a.tag}-{cell}-s{seed}"
            sets = {**common_typed, **overrides(arms), "optim.seed": seed, "optim.iterations": steps[cell],
                    "optim.eval_every": max(1, steps[cell] // a.points), "data.split_seed": a.split_seed}
            names[(cell, seed)] = name
            commands[(cell, seed)] = queue(project, name, sets, a.targets)
    t0 = time.perf_counter()
    statuses = run_queue(project, a.jobs)
    wall = time.perf_counter() - t0
    failed = {n: s for n, s in statuses.items() if n in names.values() and s != "Success"}
    runs = collect(project, grid, names, commands, statuses, calib)
    eff = effects(grid, runs)
    result = {"design": a.design, "seeds": a.seeds, "cpu_budget_s": a.cpu_budget if a.steps is None else None,
              "split_seed": a.split_seed, "factors": FACTORS, "defaults": DEFAULTS, "claims": CLAIMS,
              "targets": a.targets, "common_overrides": common_typed, "calibration": calib,
              "cells": {c: {"arms": grid[c], "overrides": overrides(grid[c]), "steps": steps[c], "runs": runs[c]}
                        for c in grid},
              "effects": eff, "bootstrap": {"resamples": RESAMPLES, "seed": BOOT_SEED},
              "queue_wall_s": wall, "jobs": a.jobs, "failed": failed, "columns": list(COLUMNS)}
    write_results(a.out, result, a.note)
    a.out.with_suffix(".md").write_text(markdown(eff, COLUMNS))
    print(f"wrote {a.out} ({len(grid)} cells x {len(a.seeds)} seeds, {len(failed)} failed)", file=sys.stderr)
    return 1 if failed else 0


def _yaml(v: str):
    import yaml

    return yaml.safe_load(v)


if __name__ == "__main__":
    sys.exit(main())
