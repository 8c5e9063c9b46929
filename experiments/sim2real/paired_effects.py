"""The effect of a change between two runs, view by view: per column, the control's RMSE minus the arm's on the same
views (positive: the arm is better), with a 95 % bootstrap interval over whole SVBRDFs (``train.evaluate.paired``).

Each pair compares two ``svtrain eval`` output folders of the same store (their ``per_view.csv``); runs trained with
the same seed on two libraries give the same views of every evaluated store, so the difference is the runs'.

    python3 experiments/sim2real/paired_effects.py --pair real_crop1 CONTROL/eval_crop1 ARM/eval_crop1 \\
        --pair heldout CONTROL/eval_heldout ARM/eval_heldout_other --out experiments/sim2real/results/effects.json

The bootstrap interval resamples SVBRDFs of one pair of runs: it leaves out training noise (weights, data order,
loss draws), which ``effects_seed.json`` measured at the same size as several claimed effects. ``--seed-noise
FILE`` (repeatable: results files of this script whose arms only change the training seed of one shared control)
adds it. Per set of the same name and column, the seed pairs' gains g_1 .. g_k place the k + 1 runs at 0, -g_1 ..
-g_k; their sample standard deviation s (ddof 1) estimates one run's training noise, so a difference of two runs
has sigma_d = sqrt(2) s (for one pair: |g_1|), and 1.96 sigma_d is added to each half of the bootstrap interval in
quadrature (``ci95_with_seed``, ``beyond_seed_noise``). A few seeds estimate sigma_d poorly: a screen against
claiming noise, not a calibrated interval.
"""
from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

COLUMNS = ("rerender", "normal", "diffuse", "roughness", "specular")


def per_view(folder: Path) -> dict[int, dict]:
    """view index -> {"svbrdf": id, column: RMSE} from an eval folder's per_view.csv."""
    with open(folder / "per_view.csv") as f:
        return {int(r["view"]): {"svbrdf": int(r["svbrdf"]), **{c: float(r[c]) for c in COLUMNS}}
                for r in csv.DictReader(f)}


def effects(control: Path, arm: Path) -> dict:
    """Per column: control and arm mean RMSE over the shared views, and the paired gain (control - arm)."""
    from train.evaluate import paired

    a, b = per_view(control), per_view(arm)
    views = sorted(set(a) & set(b))
    if not views or len(views) != len(a) or len(views) != len(b):
        raise SystemExit(f"{control} and {arm} did not evaluate the same views ({len(a)} and {len(b)}, "
                         f"{len(views)} shared)")
    if any(a[v]["svbrdf"] != b[v]["svbrdf"] for v in views):
        raise SystemExit(f"{control} and {arm} group the views into different SVBRDFs: not the same store")
    clusters = np.array([a[v]["svbrdf"] for v in views])
    out = {"views": len(views)}
    for c in COLUMNS:
        x, y = np.array([a[v][c] for v in views]), np.array([b[v][c] for v in views])
        p = paired(y, x, clusters, seed=0)
        out[c] = {"control": round(float(x.mean()), 5), "arm": round(float(y.mean()), 5),
                  "gain": round(p["gain"], 5), "ci95": [round(v, 5) for v in p["ci95"]],
                  "beyond_noise": "better" if p["ci95"][0] > 0 else "worse" if p["ci95"][1] < 0 else "no"}
    out["svbrdfs"] = int(len(np.unique(clusters)))
    return out


def seed_sigma(seed_sets: list[dict], column: str) -> float:
    """sigma_d of ``column`` from the same set of k seed pairs sharing one control (module docstring)."""
    runs = [0.0] + [-float(ss[column]["gain"]) for ss in seed_sets]
    return float(np.sqrt(2.0) * np.std(runs, ddof=1))


def with_seed_noise(e: dict, seed_sets: dict | list[dict]) -> None:
    """Add ``seed_allowance``, ``ci95_with_seed`` and ``beyond_seed_noise`` to each column of the set ``e`` from the
    same set of one or more seed pairs' results (``seed_sets``), in place (module docstring)."""
    seed_sets = [seed_sets] if isinstance(seed_sets, dict) else list(seed_sets)
    for c in COLUMNS:
        col = e[c]
        allowance = 1.96 * seed_sigma(seed_sets, c)
        lo = col["gain"] - float(np.hypot(col["gain"] - col["ci95"][0], allowance))
        hi = col["gain"] + float(np.hypot(col["ci95"][1] - col["gain"], allowance))
        col["seed_allowance"] = round(allowance, 5)
        col["ci95_with_seed"] = [round(lo, 5), round(hi, 5)]
        col["beyond_seed_noise"] = "better" if lo > 0 else "worse" if hi < 0 else "no"


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--pair", nargs=3, action="append", required=True, metavar=("NAME", "CONTROL", "ARM"),
                    help="a name and the control's and the arm's eval folders (repeatable)")
    ap.add_argument("--what", default="", help="what the arm changes (recorded)")
    ap.add_argument("--out", required=True, help="results JSON")
    ap.add_argument("--seed-noise", action="append", default=[], metavar="EFFECTS_JSON",
                    help="a seed pair's results of this script (repeatable: pairs of one control): widen each set's "
                         "intervals by the training noise they show")
    a = ap.parse_args(argv)
    seeds = [(f, json.loads(Path(f).read_text())["sets"]) for f in a.seed_noise]
    result = {"what": a.what, "gain": "control RMSE minus arm RMSE (positive: the arm is better), 95 % bootstrap "
                                       "over SVBRDFs", "sets": {}}
    for name, control, arm in a.pair:
        result["sets"][name] = {"control": control, "arm": arm, **effects(Path(control), Path(arm))}
        e = result["sets"][name]
        if seeds:
            for f, sets in seeds:
                if name not in sets:
                    raise SystemExit(f"--seed-noise {f} has no set {name!r} (it has {', '.join(sets)})")
            with_seed_noise(e, [sets[name] for _, sets in seeds])
            result["seed_noise"] = [f for f, _ in seeds]
        print(name, " ".join(f"{c} {e[c]['gain']:+.4f} [{e[c]['ci95'][0]:+.4f}, {e[c]['ci95'][1]:+.4f}]"
                             + (f" seed-widened [{e[c]['ci95_with_seed'][0]:+.4f}, {e[c]['ci95_with_seed'][1]:+.4f}]"
                                if seeds else "") for c in COLUMNS))
    write_results(a.out, result, a.note)


if __name__ == "__main__":
    main()
