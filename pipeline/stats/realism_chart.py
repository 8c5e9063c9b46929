"""The one-page chart of a `svgen stats --reference` report: every distribution's histograms side by side (the
reference filled, the stores as lines) with each store's distance and the noise floor in the panel title, and the
mean share of slope power per octave as grouped bars."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .compare import BINS, OCTAVE_STAT


def _ratios(ax, report: dict, stores: list[str], colours: dict) -> None:
    """Horizontal bars: distance / noise floor of every statistic and store (log scale, 1 = the floor)."""
    stats = list(report["distances"].values())
    y = np.arange(len(stats))
    h = 0.8 / max(len(stores), 1)
    for i, n in enumerate(stores):
        r = [d["to_reference"][n] / d["noise_floor"] if d["noise_floor"] > 0 else np.nan for d in stats]
        bars = ax.barh(y + (i - (len(stores) - 1) / 2) * h, r, h, color=colours[n], label=n)
        ax.bar_label(bars, fmt="%.1f×", fontsize=6, padding=2)
    ax.axvline(1.0, color="k", lw=1, ls="--")
    ax.set_xscale("log")
    ax.set_yticks(y, [d["label"] for d in stats], fontsize=7)
    ax.invert_yaxis()
    ax.tick_params(axis="x", labelsize=7)
    ax.set_title("distance to the reference / noise floor\n(dashed: 1, as far apart as the reference's halves)",
                 fontsize=8)


def chart(report: dict, path) -> Path:
    """Draw ``report`` (:func:`pipeline.stats.compare.compare`) into a PNG at ``path``; returns the path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ref = report["reference"]["name"]
    names = [ref] + [s["name"] for s in report["stores"]]
    hists = report["histograms"]
    fig, axes = plt.subplots(4, 4, figsize=(16, 13))
    colours = {n: f"C{i}" for i, n in enumerate(names)}
    for ax, (k, h) in zip(axes.flat, hists.items()):
        d = report["distances"][k]
        lo, hi = h["range"]
        edges = np.linspace(lo, hi, BINS + 1)
        for n in names:
            y = np.asarray(h["density"][n])
            if n == ref:
                ax.fill_between(edges[:-1], y, step="post", color="grey", alpha=0.45, label=f"{n} (reference)")
            else:
                ax.step(edges[:-1], y, where="post", color=colours[n], label=n)
        dist = ", ".join(f"{v:.3g}" for v in d["to_reference"].values())
        ax.set_title(f"{d['label']}\nW1 {dist} (floor {d['noise_floor']:.3g})", fontsize=8)
        ax.tick_params(labelsize=7)
    used = len(hists)
    ax = axes.flat[used]
    octs = report["octaves"]
    x = np.arange(len(octs))
    w = 0.8 / len(names)
    for i, n in enumerate(names):
        ax.bar(x + (i - (len(names) - 1) / 2) * w, report["octave_shares"][n], w,
               color="grey" if n == ref else colours[n], label=n)
    d = report["distances"][OCTAVE_STAT]
    ax.set_xticks(x, [f"{lo}-{hi}" for lo, hi in octs], fontsize=7)
    ax.set_xlabel("cycles per map", fontsize=8)
    ax.set_title(f"share of slope power by octave\nL1 {', '.join(f'{v:.3g}' for v in d['to_reference'].values())}"
                 f" (floor {d['noise_floor']:.3g})", fontsize=8)
    ax.legend(fontsize=7)
    row, col = divmod(used + 1, axes.shape[1])
    for extra in axes.flat[used + 1:]:
        extra.remove()
    if col + 1 < axes.shape[1]:  # the rest of the last row (one column left for its labels): every statistic's
        # distance as a multiple of its noise floor
        _ratios(fig.add_subplot(axes[0, 0].get_gridspec()[row, col + 1:]), report, names[1:], colours)
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(f"Realism: stores against the reference {ref} ({report['reference']['materials']} materials); "
                 f"floor = distance between the reference's halves (mean of {report['splits']} splits)", fontsize=10)
    # fixed margins, not tight_layout: the ratio panel's long labels would squeeze every column
    fig.subplots_adjust(left=0.04, right=0.98, top=0.92, bottom=0.05, hspace=0.5, wspace=0.25)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path
