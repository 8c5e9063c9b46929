"""`svgen stats`: the distribution of every map over a store, so imported and procedural libraries can be compared
before training.

Per store (variants, blends, stress, or the base maps of a renders store), over its materials (all, or an evenly
spaced ``limit`` of them), on every ``stride``-th pixel of each map:

* per-channel histograms (32 bins on [0, 1]; normals as the slope angle in degrees, 0..90) and mean / median;
* spatial variation within a material: the standard deviation over the material's pixels, averaged over materials
  (diffuse and specular on luminance Y = 0.2126 R + 0.7152 G + 0.0722 B of the linear values);
* specular colour saturation: (max - min) / max of each material's mean F0 (0: grey dielectric, > 0: coloured metal);
* diffuse-specular correlation: Pearson's r over materials of mean diffuse Y and mean specular Y;
* normal slope spread: per material the standard deviation of the slope angle arccos(n_z), averaged;
* roughness histogram (the per-channel histogram of roughness).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from materials.maps import MAP_NAMES

from svcore.errors import StoreError
from svcore.progress import progress

from storage.store import open_store

BINS = 32
LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)
KINDS = ("variants", "blends", "stress", "renders")


def maps_reader(path):
    """(kind, number of materials, i -> SVBRDF maps) of a variants, blends, stress or renders store (base maps)."""
    g = open_store(path, KINDS)
    kind = dict(g.attrs)["svgen"]["kind"]
    if kind == "renders":
        from storage.renders_store import RendersReader

        r = RendersReader(path)
        return kind, r.n_svbrdf, r.base_maps
    from storage.svbrdf_store import SVBRDFStore

    s = SVBRDFStore(path)
    return kind, len(s), s.maps


def store_stats(path, limit: int | None = None, stride: int = 4) -> dict:
    """Statistics of one store (see the module docstring).

    Returns:
        {"store", "kind", "materials", "maps": {map: {"mean", "median", "hist"}}, "summary": {name: value}}.
    """
    kind, n, maps_of = maps_reader(path)
    if n == 0:
        raise StoreError(f"{path} holds no materials")
    idx = np.unique(np.linspace(0, n - 1, min(n, limit or n)).round().astype(int))
    pix = {k: [] for k in MAP_NAMES}
    per = {"diffuse_y_std": [], "specular_y_std": [], "roughness_std": [], "slope_std_deg": [],
           "diffuse_y_mean": [], "specular_y_mean": [], "specular_saturation": [], "roughness_mean": [],
           "slope_mean_deg": []}
    with progress(len(idx), "stats", unit="material") as bar:
        for i in idx:
            m = maps_of(int(i))
            sub = {k: getattr(m, k)[::stride, ::stride].reshape(-1, getattr(m, k).shape[-1]) for k in MAP_NAMES}
            slope = np.degrees(np.arccos(np.clip(sub["normal"][:, 2], -1, 1)))
            dy, sy = sub["diffuse"] @ LUMA, sub["specular"] @ LUMA
            f0 = sub["specular"].mean(0)
            per["diffuse_y_std"].append(dy.std())
            per["specular_y_std"].append(sy.std())
            per["roughness_std"].append(sub["roughness"].std())
            per["slope_std_deg"].append(slope.std())
            per["diffuse_y_mean"].append(dy.mean())
            per["specular_y_mean"].append(sy.mean())
            per["specular_saturation"].append(float((f0.max() - f0.min()) / max(f0.max(), 1e-6)))
            per["roughness_mean"].append(sub["roughness"].mean())
            per["slope_mean_deg"].append(slope.mean())
            pix["normal"].append(slope[:, None])
            for k in ("diffuse", "specular", "roughness"):
                pix[k].append(sub[k])
            bar.update(1)
    out = {"store": str(path), "kind": kind, "materials": int(len(idx)), "maps": {}, "per_material": {}}
    for k, parts in pix.items():
        a = np.concatenate(parts)
        lo, hi = (0.0, 90.0) if k == "normal" else (0.0, 1.0)
        out["maps"][k if k != "normal" else "normal_slope_deg"] = {
            "mean": [float(x) for x in a.mean(0)], "median": [float(x) for x in np.median(a, 0)],
            "p05": [float(x) for x in np.percentile(a, 5, 0)], "p95": [float(x) for x in np.percentile(a, 95, 0)],
            "range": [lo, hi],
            "hist": [np.histogram(a[:, c], BINS, (lo, hi))[0].tolist() for c in range(a.shape[1])]}
    per = {k: np.asarray(v, np.float64) for k, v in per.items()}
    out["per_material"] = {k: v.tolist() for k, v in per.items()}
    corr = (float(np.corrcoef(per["diffuse_y_mean"], per["specular_y_mean"])[0, 1])
            if len(idx) > 1 and per["diffuse_y_mean"].std() > 0 and per["specular_y_mean"].std() > 0 else float("nan"))
    out["summary"] = {
        "diffuse Y median": float(np.median(np.concatenate(pix["diffuse"]) @ LUMA)),
        "specular Y median": float(np.median(np.concatenate(pix["specular"]) @ LUMA)),
        "specular Y p05": float(np.percentile(np.concatenate(pix["specular"]) @ LUMA, 5)),
        "specular Y p95": float(np.percentile(np.concatenate(pix["specular"]) @ LUMA, 95)),
        "roughness median": float(np.median(np.concatenate(pix["roughness"]))),
        "slope median (deg)": float(np.median(np.concatenate(pix["normal"]))),
        "diffuse Y spatial std": float(per["diffuse_y_std"].mean()),
        "specular Y spatial std": float(per["specular_y_std"].mean()),
        "roughness spatial std": float(per["roughness_std"].mean()),
        "slope spread (deg)": float(per["slope_std_deg"].mean()),
        "specular saturation": float(per["specular_saturation"].mean()),
        "diffuse-specular r": corr,
    }
    return out


def table(results: list[dict]) -> str:
    """Markdown table: one row per summary statistic, one column per store."""
    heads = [f"{Path(r['store']).name} ({r['kind']}, {r['materials']})" for r in results]
    lines = ["| statistic | " + " | ".join(heads) + " |", "|---|" + "---:|" * len(results)]
    for key in results[0]["summary"]:
        lines.append(f"| {key} | " + " | ".join(f"{r['summary'][key]:.4g}" for r in results) + " |")
    return "\n".join(lines)


def chart(results: list[dict], path) -> Path:
    """Histograms of every map (stores overlaid, normalised to density) and per-material spatial variation."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [("diffuse", "diffuse (linear, per channel mean)"), ("specular", "specular F0 (linear)"),
              ("roughness", "roughness"), ("normal_slope_deg", "normal slope angle (deg)")]
    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5))
    for ax, (k, title) in zip(axes.flat, panels):
        for r in results:
            m = r["maps"][k]
            lo, hi = m["range"]
            h = np.asarray(m["hist"], np.float64).mean(0)
            edges = np.linspace(lo, hi, BINS + 1)
            ax.step(edges[:-1], h / max(h.sum(), 1), where="post", label=Path(r["store"]).name)
        ax.set_title(title)
        ax.set_yscale("log")
    for ax, (k, title) in zip(axes.flat[4:], [("specular_y_std", "specular Y std within a material"),
                                                ("diffuse_y_std", "diffuse Y std within a material")]):
        vals = [np.asarray(r["per_material"][k]) for r in results]
        hi = max(float(v.max()) for v in vals) or 1.0
        for r, v in zip(results, vals):
            ax.hist(v, bins=24, range=(0, hi), histtype="step", density=True, label=Path(r["store"]).name)
        ax.set_title(title)
    axes.flat[0].legend(fontsize=8)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
