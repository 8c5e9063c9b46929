"""Chart 6: bytes per view against CPU-s per view of every codec and layout -- rebuilt from codecs.json alone.

Left: encode + write CPU, right: read + decode CPU, both per 256^2 view of the renders store, against its bytes
per view; one point per codec pipeline and layout (marker: today's unsharded chunks, a shard per today's task,
a shard per larger task), colour by family; the issue's aim box (<= 10 ms end to end per view, render included,
and <= 150 KB per view) drawn; the applied default, the knee and the layout before #12 circled. Drawn by
``python3 benchmarks/charts`` (the DVC charts stage) from this finished experiment's frozen results.

Usage: python3 experiments/store_codecs/chart_codecs.py [codecs.json] [out.png]
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

# harness.py stays in benchmarks/; this finished experiment imports it from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import IMG, pyplot, save_figure  # noqa: E402

#: this experiment's frozen results (experiments/store_codecs/results/)
DEFAULT_JSON = Path(__file__).resolve().parent / "results" / "codecs.json"
DEFAULT_PNG = IMG / "chart_codecs.png"
COLOURS = {"zstd": "tab:blue", "blosc": "tab:orange", "delta": "tab:green"}


def plot(json_path: str | Path = DEFAULT_JSON, png_path: str | Path = DEFAULT_PNG) -> Path:
    """Draw chart 6 from the benchmark's JSON.

    Args:
        json_path: experiments/store_codecs/results/codecs.json (written by bench_codecs.py).
        png_path: where to write the PNG (parent directories are created).

    Returns:
        The PNG path.
    """
    from matplotlib.patches import Rectangle
    from matplotlib.ticker import ScalarFormatter

    plt = pyplot()
    d = json.loads(Path(json_path).read_text())
    store = d["stores"]["renders"]
    rows, aims, chosen = store["rows"], d["aims"], d["chosen"]
    layouts = list(dict.fromkeys(r["layout"] for r in rows))
    markers = dict(zip(layouts, "osv^D"))
    fig, axes = plt.subplots(1, 2, figsize=(14, 5), sharey=True)
    for ax, key, what in ((axes[0], "write_cpu_s_per_view", "encode + write"),
                          (axes[1], "read_cpu_s_per_view", "read + decode")):
        ax.add_patch(Rectangle((0, 0), aims["cpu_s_per_view_end_to_end"] * 1e3, aims["bytes_per_view"] / 1e3,
                               fc="tab:green", alpha=0.08, ec="tab:green", ls="--",
                               label="aim: ≤ 10 ms/view end to end (render incl.), ≤ 150 KB/view"
                               if ax is axes[0] else None))
        for lay in layouts:
            pts = [r for r in rows if r["layout"] == lay]
            ax.scatter([r[key] * 1e3 for r in pts], [r["bytes_per_view"] / 1e3 for r in pts],
                       c=[COLOURS.get(r["family"], "grey") for r in pts], marker=markers[lay], s=30)
            if ax is axes[0]:
                ax.scatter([], [], c="grey", marker=markers[lay],
                           label=f"layout {lay} ({pts[0]['objects_per_10k_views']:.0f} objects / 10k views)")
            if lay == chosen["layout"]:
                for r in pts:
                    ax.annotate(r["codec"], (r[key] * 1e3, r["bytes_per_view"] / 1e3), fontsize=6,
                                xytext=(3, 2), textcoords="offset points")
        # labels say what the stores do (chosen["stores_codec"]: storage/local.py's codec when measured)
        ours = chosen.get("stores_codec")
        knee = "knee, applied" if chosen["codec"] == ours else "knee (not applied)"
        marks = [(d["today"], "black", "before #12"), (chosen, "red", knee)]
        if chosen.get("in_spec") and chosen["in_spec"]["codec"] != chosen["codec"]:
            spec = chosen["in_spec"]["codec"] == ours
            marks.append((chosen["in_spec"], "purple",
                          "applied: best among zarr v3 spec codecs" if spec else "best among zarr v3 spec codecs"))
        for m, colour, label in marks:
            r = next((x for x in rows if x["codec"] == m["codec"] and x["layout"] == m["layout"]), None)
            if r is None:
                continue
            ax.scatter([r[key] * 1e3], [r["bytes_per_view"] / 1e3], s=180, facecolors="none", edgecolors=colour,
                       linewidths=1.5, zorder=5, label=f"{label}: {r['codec']}, {r['layout']}" if ax is axes[0]
                       else None)
        ax.set(xscale="log", xlabel=f"{what} CPU ms per view", title=f"{what} ({store['samples']} SVBRDFs × "
               f"{store['views_per_sample']} views)")
        ax.grid(alpha=0.3, which="both")
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(ScalarFormatter())
        ax.tick_params(axis="x", which="minor", labelsize=6)
    axes[0].set_ylabel("KB per view (renders store, all arrays)")
    top = max(r["bytes_per_view"] for r in rows) / 1e3
    axes[0].set_ylim(min(aims["bytes_per_view"] / 1e3 * 0.8, 100), top * 1.08)
    for fam, c in COLOURS.items():
        axes[0].scatter([], [], c=c, label=f"codec family: {fam}")
    handles, labels = axes[0].get_legend_handles_labels()
    axes[1].legend(handles, labels, fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.suptitle(f"Codecs and sharding of the renders store (stores write: {chosen.get('stores_codec', '?')}; "
                 f"knee: {chosen['codec']}, {chosen['layout']})",
                 fontsize=10)
    return save_figure(fig, png_path, dpi=110)


if __name__ == "__main__":
    print(plot(*sys.argv[1:3]))
