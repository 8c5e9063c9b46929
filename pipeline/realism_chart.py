"""The one-page chart of a `svgen stats --reference` report: every distribution's histograms side by side (the
reference filled, the stores as lines) with each store's distance and the noise floor in the panel title, and the
mean share of slope power per octave as grouped bars."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .realism_compare import BINS, OCTAVE_STAT


def chart(report: dict, path) -> Path:
    """Draw ``report`` (:func:`pipeline.realism_compare.compare`) into a PNG at ``path``; returns the path."""
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
    for extra in axes.flat[used + 1:]:
        extra.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(f"Realism: stores against the reference {ref} ({report['reference']['materials']} materials); "
                 f"floor = distance between the reference's halves (mean of {report['splits']} splits)", fontsize=10)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path
