"""Chart 7: what the paper's choices buy here -- held-out error against training CPU time, per claim, the paper's
choice and its alternative side by side with their seed spread; rebuilt from ablation.json alone
(benchmarks/ablation.py). Drawn by ``python3 benchmarks/charts`` (the DVC charts stage) from this finished grid's
frozen results.

One panel per claim (global track, rendering loss vs L1 on the maps, the normal term, blends): each arm's held-out
re-render RMSE along its fit (runs/train/heldout.csv of every experiment: the same held-out views for every cell)
against the training CPU seconds (the calibrated cost of the cell at each step, ablation.py's ``cpu_axis``; a grid
run with ``--steps`` and no calibration: against steps), the mean over seeds as a line and the seeds' range as a
band. The effects table
(each claim's mean difference and bootstrap interval per column and suite) is written beside the PNG as markdown.

Usage: python3 experiments/ablation/chart_ablation.py [ablation.json] [out.png]
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

# harness.py and ablation_effects.py stay in benchmarks/ (the grid is a maintained tool); this finished run's chart
# imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from ablation_effects import markdown  # noqa: E402
from harness import IMG, pyplot, save_figure  # noqa: E402

DEFAULT_JSON = Path(__file__).resolve().parent / "results" / "ablation.json"
DEFAULT_PNG = IMG / "chart_ablation.png"
COLOURS = ("tab:blue", "tab:orange")


def curve(runs: dict, column: str = "rerender", x: str = "cpu_s") -> tuple[np.ndarray, ...] | None:
    """(x, mean, low, high) over the seeds of one cell, on the steps every seed evaluated (``x``: ``cpu_s``, the
    seeds' mean CPU seconds at that step, or ``step``)."""
    curves = [r["heldout_curve"] for r in runs.values() if r.get("heldout_curve")]
    if not curves:
        return None
    steps = sorted(set.intersection(*({row["step"] for row in c} for c in curves)))
    at = [{row["step"]: row for row in c} for c in curves]
    cpu = np.array([[a[s][x] for s in steps] for a in at], np.float64).mean(0)
    err = np.array([[a[s][column] for s in steps] for a in at])
    return cpu, err.mean(0), err.min(0), err.max(0)


def plot(json_path: str | Path = DEFAULT_JSON, png_path: str | Path = DEFAULT_PNG) -> Path:
    """Draw chart 7 and write the effects table (``<png stem>.md``) beside it; returns the PNG path."""
    plt = pyplot()
    d = json.loads(Path(json_path).read_text())
    claims = [(name, e) for name, e in d["effects"].items()]
    rows = [row for c in d["cells"].values() for r in c["runs"].values() for row in r.get("heldout_curve") or []]
    x = "cpu_s" if rows and all("cpu_s" in row for row in rows) else "step"  # no calibration: steps
    n = max(1, len(claims))
    ncols = min(3, n)  # wrapped: five panels in one row are too small to read at the README's width
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.6 * ncols, 3.9 * nrows), squeeze=False)
    flat = axes.ravel()
    for ax in flat[len(claims):]:
        ax.set_visible(False)
    for ax, (name, e) in zip(flat, claims):
        for colour, (role, cells) in zip(COLOURS, (("choice", [p[0] for p in e["pairs"]]),
                                                   ("alternative", [p[1] for p in e["pairs"]]))):
            for k, cell in enumerate(dict.fromkeys(cells)):
                c = curve(d["cells"][cell]["runs"], x=x)
                if c is None:
                    continue
                cpu, mean, lo, hi = c
                label = f"{e[role]} ({cell})" if k == 0 else None
                ax.plot(cpu, mean, color=colour, marker="o", ms=3, label=label, alpha=1.0 if k == 0 else 0.5)
                ax.fill_between(cpu, lo, hi, color=colour, alpha=0.2, lw=0)
        # the claim's held-out re-render effect in the title: what the panel shows, as a number with its interval
        eff = ((e.get("suites") or {}).get("heldout") or {}).get("rerender")
        sub = (f"\nheld-out re-render: {eff['mean']:+.4f} [{eff['ci95'][0]:+.4f}, {eff['ci95'][1]:+.4f}]"
               if eff else "")
        ax.set_title(f"{name}{sub}", fontsize=10)
        ax.set_xlabel("training CPU seconds" if x == "cpu_s" else "training steps")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    for row in axes:
        row[0].set_ylabel("held-out re-render RMSE")
    n_seeds = len(d.get("seeds", []))
    fig.suptitle(f"What the paper's choices buy here ({d['design']} design, {n_seeds} seed(s) per cell; "
                 "line: seed mean, band: seed range; title: alternative minus choice, 95 % interval)", fontsize=10)
    fig.tight_layout()
    out = save_figure(fig, Path(png_path), dpi=110)
    Path(png_path).with_suffix(".md").write_text(markdown(d["effects"], tuple(d["columns"])))
    return out


if __name__ == "__main__":
    plot(*sys.argv[1:3])
