"""Chart 4: the loss renderer (torch) against Mitsuba at increasing spp -- rebuilt from agreement.json alone.

Left: relative RMSE of the Mitsuba render against torch's pixel-centre render, per samples per pixel, for the
``independent`` sampler (pooled and per material) and the ``centre`` sampler; the dotted line is the same
independent render against torch's pixel integral (noise only), the dashed line the 1 % contract.
Right: the same error against Mitsuba's wall time per view; the data stage's default (centre, 1 spp) marked.

Usage: python3 benchmarks/charts/agreement.py [agreement.json] [out.png]
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

if not __package__:  # run as a file (python3 benchmarks/charts/...): harness.py is one folder up
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from harness import IMG, RESULTS, pyplot, save_figure  # noqa: E402

DEFAULT_JSON = RESULTS / "agreement.json"
DEFAULT_PNG = IMG / "chart_agreement.png"


def chart_agreement(json_path: str | Path = DEFAULT_JSON, png_path: str | Path = DEFAULT_PNG) -> Path:
    """Draw chart 4 from the benchmark's JSON.

    Args:
        json_path: benchmarks/results/agreement.json (written by bench_agreement.py).
        png_path: where to write the PNG (parent directories are created).

    Returns:
        The PNG path.
    """
    import matplotlib

    plt = pyplot()
    data = json.loads(Path(json_path).read_text())
    rows = data["settings"]
    by = {s: sorted((r for r in rows if r["sampler"] == s), key=lambda r: r["spp"]) for s in ("independent", "centre")}
    contract = data.get("contract_rel_rmse", 0.01)

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2))
    ind, cen = by["independent"], by["centre"]
    ax.plot([r["spp"] for r in ind], [r["rel_rmse"] for r in ind], "o-", color="C0", lw=2,
            label="independent sampler (pooled)")
    for k, name in enumerate(m["material"] for m in data["materials"]):
        ys = [next(p["rel_rmse"] for p in r["per_material"] if p["material"] == name) for r in ind]
        ax.plot([r["spp"] for r in ind], ys, "-", color="C0", alpha=0.3, lw=1,
                label="per material" if k == 0 else None)
    ax.plot([r["spp"] for r in ind], [r["rel_rmse_vs_integral"] for r in ind], "o:", color="C2",
            label="independent vs torch pixel integral (noise only)")
    ax.plot([r["spp"] for r in cen], [r["rel_rmse"] for r in cen], "s-", color="C1", lw=2,
            label="centre sampler (k x k grid centres; k > 1 tends to the pixel integral)")
    floor = data["agreement_floor"]
    ax.annotate(f"floor {floor['rel_rmse']:.1e}\n(data default: centre, 1 spp)", (1, floor["rel_rmse"]),
                textcoords="offset points", xytext=(10, -4), fontsize=8)
    ax.axhline(contract, ls="--", color="k", lw=1, label=f"{contract:.0%} contract")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("Mitsuba samples per pixel")
    ax.set_ylabel("relative RMSE vs torch flash render")
    ax.set_title(f"torch loss renderer vs Mitsuba, {data['res']}$^2$, {len(data['materials'])} presets")
    ax.legend(fontsize=7, loc="center right")
    ax.grid(True, which="both", alpha=0.3)

    for rs, style, color, lab in ((ind, "o-", "C0", "independent"), (cen, "s-", "C1", "centre")):
        bx.plot([r["mitsuba_wall_s_per_view"] * 1e3 for r in rs], [r["rel_rmse"] for r in rs], style, color=color,
                label=lab)
        for r in rs:
            bx.annotate(str(r["spp"]), (r["mitsuba_wall_s_per_view"] * 1e3, r["rel_rmse"]), fontsize=7,
                        textcoords="offset points", xytext=(4, 3))
    d = cen[0]
    bx.plot([d["mitsuba_wall_s_per_view"] * 1e3], [d["rel_rmse"]], "*", ms=14, color="C3", label="data default")
    bx.axhline(contract, ls="--", color="k", lw=1)
    bx.set_xscale("log")
    bx.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    bx.set_yscale("log")
    bx.set_xlabel("Mitsuba wall ms per view (labels: spp)")
    bx.set_ylabel("relative RMSE vs torch")
    bx.set_title("error against render time")
    bx.legend(fontsize=7)
    bx.grid(True, which="both", alpha=0.3)
    return save_figure(fig, png_path, dpi=120)


if __name__ == "__main__":
    args = sys.argv[1:]
    print(chart_agreement(*(args[:2] if args else ())))
