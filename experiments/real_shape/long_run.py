"""Issue #39 after round 12: the bundled model trained on for much longer, across sittings, to see where its normals go.

Twelve rounds found no arm that moves real normals at a 2-core budget, and rounds 11-12 put the limit on training
time: the network fits normals given passes (0.73 of flat on 12 SVBRDFs at 200 passes, still falling), the default
library's 7,030 training views get about 14 passes in the bundled model's 12,000 steps, and the library's texture is
not what slows it. The issue allows the bundled model to train longer than an hour, resumed across sittings from its
timed checkpoints; this is that run: the bundled model, params.yaml's train config on the default store (control.py's
``train/renders.zarr``), ``--steps`` more steps at the fine-tunes' lr (3e-4, cosine to 5 %), two torch threads.

Each sitting reruns ``--phase fit``: ``svtrain fit`` resumes from the run's checkpoint (written every 5 minutes),
so a kill loses at most 5 minutes and the result is the uninterrupted run's bytes (tests/test_dvc_pipeline.py holds
``fit``'s resume to that). ``--phase eval`` evaluates the newest checkpoint (copied aside, keyed by its step) on 100
training views, 200 held-out views and the 32 real materials, and adds it to the curve in
``results/long_run.json``: normal over flat, and every column, by step.

    python3 experiments/real_shape/long_run.py --work runs/rs --out-dir runs/long --phase fit    # every sitting
    python3 experiments/real_shape/long_run.py --work runs/rs --out-dir runs/long --phase eval
(the eval: about 2 minutes quiet, 15 beside the two-thread fit)
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).parent))

from control import PARAMS, evaluate, table  # noqa: E402

TRAIN_VIEWS, HELDOUT_VIEWS, THREADS = 100, 200, 2


def fit_cmd(store: Path, out: Path, steps: int) -> list[str]:
    return ["svtrain", "fit", "--params", PARAMS, "--store", str(store), "--out", str(out), "--init", "bundled",
            "--iterations", str(steps), "--workers", "0", "--set", f"optim.threads={THREADS}",
            "--set", "optim.lr=0.0003", "--set", "optim.checkpoint_minutes=5"]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--work", default=str(ROOT / "runs" / "rs"), help="control.py's scratch folder")
    ap.add_argument("--out-dir", required=True, help="the run's folder (keep it between sittings)")
    ap.add_argument("--steps", type=int, default=24000, help="steps after the bundled model's (fixed for the run)")
    ap.add_argument("--phase", choices=("fit", "eval"), required=True)
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "long_run.json"))
    a = ap.parse_args(argv)
    work, out_dir = Path(a.work).resolve(), Path(a.out_dir).resolve()
    store, refs = work / "train" / "renders.zarr", sorted(work.glob("fold*/ref/renders.zarr"))
    if not store.is_dir() or not refs:
        raise SystemExit(f"{work} has no train/renders.zarr or fold*/ref/renders.zarr: run control.py --phase stores")
    run = out_dir / "run"
    if a.phase == "fit":
        out_dir.mkdir(parents=True, exist_ok=True)
        with open(out_dir / "fit.log", "a") as f:
            cmd = fit_cmd(store, run, a.steps)
            f.write("$ " + " ".join(cmd) + "\n")
            f.flush()
            r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT,
                               env={**os.environ, "SVGEN_NO_PROGRESS": "1", "OMP_NUM_THREADS": str(THREADS)})
        raise SystemExit(r.returncode)
    src = run / "model.pt" if (run / "model.pt").is_file() else run / "checkpoint.pt"
    if not src.is_file():
        raise SystemExit(f"{run} has no checkpoint yet: run --phase fit first")
    step = int(torch.load(src, weights_only=False)["step"])
    at = out_dir / f"step_{step}"
    at.mkdir(exist_ok=True)
    ckpt = at / "ckpt.pt"
    if not ckpt.is_file():
        shutil.copy(src, ckpt)
    log = out_dir / "commands.log"
    point = {"train_views": table(evaluate(ckpt, at / "eval_train", log, "--suite", "train", "--store", str(store),
                                           "--limit", str(TRAIN_VIEWS))),
             "heldout": table(evaluate(ckpt, at / "eval_heldout", log, "--suite", "heldout", "--store", str(store),
                                       "--limit", str(HELDOUT_VIEWS)))}
    for i, ref in enumerate(refs):
        point[f"reference_{i}"] = table(evaluate(ckpt, at / f"eval_ref{i}", log, "--store", str(ref)))
    out = Path(a.out)
    res = json.loads(out.read_text()) if out.is_file() else {
        "question": "where do the bundled model's normals go when it trains much longer (issue #39: the budget)?",
        "command": " ".join(fit_cmd(Path("STORE"), Path("OUT"), a.steps)).replace(PARAMS, "params.yaml"),
        "steps_after_bundled": a.steps, "curve": {}}
    res["curve"][str(step)] = point
    res["curve"] = dict(sorted(res["curve"].items(), key=lambda kv: int(kv[0])))
    out.write_text(json.dumps(res, indent=1) + "\n")
    print(step, {k: v["normal_over_flat"] for k, v in point.items()})
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
