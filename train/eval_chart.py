"""The picture of an evaluation: per column (re-render, normal, diffuse, roughness, specular) one panel of bars,
one bar group per evaluation group (the held-out split, each stress category), model beside the baselines.

A baseline's bar carries the 95 % bootstrap interval that ``evaluate.paired`` computed for the model's gain over
it: the whisker spans model RMSE + [low, high] of the gain (the bar's top, model + mean gain, lies inside it). A
whisker whose lower end stays above the model's bar says the model beats that baseline beyond the spread of the
evaluated SVBRDFs; one that reaches below it says the difference is within that spread."""
from __future__ import annotations

from pathlib import Path

METHODS = {"model": ("model", "tab:blue"), "input_as_diffuse": ("input as diffuse", "0.55"),
           "dataset_mean": ("dataset mean", "0.8")}


def groups_of(res: dict) -> dict[str, dict]:
    """{group: {method: {column: RMSE}, "samples": n}} of an ``eval.json`` (one-group or multi-group suite)."""
    return res["groups"] if "groups" in res else {res.get("suite", "heldout"): res}


def _interval(groups: dict[str, dict], names: list[str], method: str, col: str):
    """(2, n) whisker lengths below/above each group's bar of ``method`` from the paired gain interval, or None
    (the model's own bars, and results without paired statistics)."""
    import numpy as np

    if method == "model" or not any("paired" in groups[g] for g in names):
        return None
    err = np.zeros((2, len(names)))
    for i, g in enumerate(names):
        p = groups[g].get("paired", {}).get(method, {}).get(col)
        if p:  # the bar's top is model + gain: the whisker spans model + ci95
            err[:, i] = [p["gain"] - p["ci95"][0], p["ci95"][1] - p["gain"]]
    return np.clip(err, 0, None)


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
            ax.bar(x + (k - (len(METHODS) - 1) / 2) * width, vals, width, color=colour, label=label,
                   yerr=_interval(groups, names, m, col), capsize=2, error_kw={"elinewidth": 0.8})
        ax.set_title(col, fontsize=10)
        ax.set_xticks(x, [f"{g} ({groups[g].get('samples', '?')})" for g in names], rotation=60, ha="right",
                      fontsize=7)
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylabel("RMSE (lower is better)")
    if any("paired" in r for r in groups.values()):
        fig.text(0.5, 0.005, "whiskers: model RMSE + 95 % bootstrap interval (over SVBRDFs) of the paired gain",
                 ha="center", fontsize=7)
    axes[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    png = Path(png_path)
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png)
    plt.close(fig)
    return png
