"""The effect of one of the paper's choices between two arms of the ablation grid (benchmarks/ablation.py).

An effect is the mean per-view RMSE of the alternative arm minus that of the paper's choice (positive: the choice
lowers the error), over the same evaluated views and every training seed. Its 95 % interval is a bootstrap over
the two sources of spread at once: whole SVBRDFs (the views of one SVBRDF share their maps, so they are resampled
together) and training seeds (each arm's seeds resampled on their own: seed k of one arm is no pair of seed k of
the other).
"""
from __future__ import annotations

import numpy as np

#: resamples of the bootstrap and its seed (recorded in ablation.json beside the intervals).
RESAMPLES = 2000
BOOT_SEED = 0


def effect(err_choice: np.ndarray, err_alt: np.ndarray, clusters: np.ndarray, resamples: int = RESAMPLES,
           seed: int = BOOT_SEED) -> dict:
    """Mean difference alt - choice with its cluster-and-seed bootstrap interval.

    Args:
        err_choice: (S_a, V) per-view RMSE of the paper's choice, one row per training seed.
        err_alt: (S_b, V) the same views under the alternative arm.
        clusters: (V,) SVBRDF id of each view.

    Returns:
        {"mean", "ci95": [low, high], "svbrdfs", "seeds": [S_a, S_b], "choice", "alternative"} (the last two: the
        arms' mean RMSEs).
    """
    a, b = np.atleast_2d(np.asarray(err_choice, np.float64)), np.atleast_2d(np.asarray(err_alt, np.float64))
    if a.shape[1] != b.shape[1] or a.shape[1] != len(clusters):
        raise ValueError(f"arms evaluated on different views: {a.shape} vs {b.shape} vs {len(clusters)} ids")
    ids, inv = np.unique(np.asarray(clusters), return_inverse=True)
    n = np.bincount(inv, minlength=len(ids)).astype(np.float64)
    sa = np.stack([np.bincount(inv, weights=r, minlength=len(ids)) for r in a])  # (S_a, C) per-SVBRDF sums
    sb = np.stack([np.bincount(inv, weights=r, minlength=len(ids)) for r in b])
    rng = np.random.default_rng(seed)
    boot = np.empty(resamples)
    for k in range(resamples):
        c = rng.integers(0, len(ids), len(ids))
        ia, ib = rng.integers(0, len(a), len(a)), rng.integers(0, len(b), len(b))
        boot[k] = (sb[ib][:, c].sum(1).mean() - sa[ia][:, c].sum(1).mean()) / n[c].sum()
    lo, hi = np.quantile(boot, [0.025, 0.975])
    return {"mean": float(b.mean() - a.mean()), "ci95": [float(lo), float(hi)], "svbrdfs": int(len(ids)),
            "seeds": [int(len(a)), int(len(b))], "choice": float(a.mean()), "alternative": float(b.mean())}


def markdown(effects: dict, columns: tuple[str, ...]) -> str:
    """The effects table: one row per claim and suite, one column per error column (mean [95 % interval])."""
    lines = ["| claim | paper's choice | against | suite | " + " | ".join(columns) + " |",
             "|---|---|---|---|" + "---|" * len(columns)]
    for claim, e in effects.items():
        for suite, cols in e["suites"].items():
            cells = [f"{cols[c]['mean']:+.4f} [{cols[c]['ci95'][0]:+.4f}, {cols[c]['ci95'][1]:+.4f}]"
                     if c in cols else "–" for c in columns]
            lines.append(f"| {claim} | {e['choice']} | {e['alternative']} | {suite} | " + " | ".join(cells) + " |")
    lines += ["", "RMSE of the alternative minus RMSE of the paper's choice (positive: the choice helps), mean over "
              "the evaluated views and training seeds; 95 % bootstrap interval over SVBRDFs and seeds."]
    return "\n".join(lines) + "\n"
