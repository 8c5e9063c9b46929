"""The picture of an evaluation: per column (re-render, normal, diffuse, roughness, specular) one panel of bars,
one bar group per evaluation group (the held-out split, each stress category), model beside the baselines."""
from __future__ import annotations

from pathlib import Path

METHODS = {"model": ("model", "tab:blue"), "input_as_diffuse": ("input as diffuse", "0.55"),
           "dataset_mean": ("dataset mean", "0.8")}


def groups_of(res: dict) -> dict[str, dict]:
    """{group: {method: {column: RMSE}, "samples": n}} of an ``eval.json`` (one-group or multi-group suite)."""
    return res["groups"] if "groups" in res else {res.get("suite", "heldout"): res}


def plot_eval(groups: dict[str, dict], png_path: str | Path, title: str) -> Path:
    """Write the bar chart of ``groups`` (see :func:`groups_of`) to ``png_path``; returns the path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    names = list(groups)
    # the columns are those of the results, in their order: a new metric needs no change here (and this module
    # needs nothing from train.evaluate, which imports it)
    COLUMNS = list(next(r[m] for r in groups.values() for m in METHODS if m in r))
    fig, axes = plt.subplots(1, len(COLUMNS), figsize=(3.0 * len(COLUMNS), 3.6), dpi=100, sharey=False)
    x = np.arange(len(names))
    width = 0.8 / len(METHODS)
    for ax, col in zip(axes, COLUMNS):
        for k, (m, (label, colour)) in enumerate(METHODS.items()):
            vals = [groups[g][m][col] if m in groups[g] else np.nan for g in names]
            ax.bar(x + (k - (len(METHODS) - 1) / 2) * width, vals, width, color=colour, label=label)
        ax.set_title(col, fontsize=10)
        ax.set_xticks(x, [f"{g} ({groups[g].get('samples', '?')})" for g in names], rotation=60, ha="right",
                      fontsize=7)
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylabel("RMSE (lower is better)")
    axes[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    png = Path(png_path)
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png)
    plt.close(fig)
    return png
