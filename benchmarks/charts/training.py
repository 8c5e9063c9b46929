"""Chart 2 of #5: held-out re-render RMSE against training wall time, one line per network width.

Reads the JSON of ``experiments/train_budget/bench_train_budget.py`` (a finished width sweep, frozen there);
baselines are horizontal lines, the compact default is drawn heavier, with a star at its end of budget. A DVC
charts stage can rebuild the PNG from the JSON alone:

    python3 benchmarks/charts/training.py \
        [experiments/train_budget/results/train_budget.json [docs/img/chart_training.png]]
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

if not __package__:  # run as a file (python3 benchmarks/charts/...): harness.py is one folder up
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from harness import IMG, ROOT, pyplot, save_figure  # noqa: E402

DEFAULT_JSON = ROOT / "experiments" / "train_budget" / "results" / "train_budget.json"
DEFAULT_PNG = IMG / "chart_training.png"

BASELINE_STYLE = {"input_as_diffuse": ("input as diffuse", "0.35", "--"),
                  "dataset_mean": ("dataset mean", "0.6", ":")}


def plot(json_path=DEFAULT_JSON, png_path=DEFAULT_PNG) -> Path:
    """Render the chart of ``json_path`` (bench_train_budget output) to ``png_path``; returns the PNG path."""
    plt = pyplot()
    res = json.loads(Path(json_path).read_text())
    default = res.get("compact_default")
    fig, ax = plt.subplots(figsize=(7, 5.0), dpi=110)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, row in enumerate(sorted(res["widths"], key=lambda r: r["base_width"])):
        pts = row["points"]
        x = [p.get("budget_s", p["wall_s"]) / 60 for p in pts]  # quiet-equivalent when calibrated apart
        y = [p["rerender"] for p in pts]
        w = row["base_width"]
        is_default = w == default
        label = f"width {w} ({row['parameters'] / 1e6:.2f} M params, {row['steps']} steps)"
        if is_default:
            label = f"compact default: {label}"
        ax.plot(x, y, marker="o", ms=4 if not is_default else 6, lw=1.2 if not is_default else 2.6,
                color=colors[k % len(colors)], label=label, zorder=3 if is_default else 2)
        if is_default:
            ax.plot([x[-1]], [y[-1]], marker="*", ms=16, color=colors[k % len(colors)], mec="k", zorder=4)
    for name, (label, color, ls) in BASELINE_STYLE.items():
        if name in res.get("baselines", {}):
            ax.axhline(res["baselines"][name]["rerender"], color=color, ls=ls, lw=1.4,
                       label=f"baseline: {label}")
    ax.set_xlabel("training time (min, 2 quiet CPU cores; evaluation excluded)")
    ax.set_ylabel("held-out re-render RMSE")
    split = res.get("split", {})
    ax.set_title(f"Eval re-render RMSE vs training time ({split.get('eval_views', '?')} held-out views, "
                 f"lr {res.get('lr', '?'):g} {res.get('schedule', 'constant')}, grad clip {res.get('grad_clip', 0):g})",
                 fontsize=10)
    ax.grid(alpha=0.3)
    ax.set_xlim(left=0)
    ax.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, frameon=False)
    return save_figure(fig, png_path)


if __name__ == "__main__":
    if len(sys.argv) > 3:
        sys.exit("usage: training.py [TRAIN_BUDGET_JSON [PNG]]")
    print(plot(*sys.argv[1:]))
