"""Distances between realism profiles, the reference's split-half noise floor, and the report of
`svgen stats --reference` (JSON-ready dict and a markdown table).

* distributions (pixel values, per-material CV and correlations): 1-D Wasserstein distance
  (scipy.stats.wasserstein_distance), in the statistic's own unit;
* normal relief by scale: L1 distance between the mean octave shares (materials with no relief left out of the
  mean), 0..2.

The noise floor is the same distance between two random halves of the reference's materials (``splits`` seeded
splits, averaged): a store closer to the reference than that is as close as the reference is to itself. Halves
hold half the materials, so the floor is on the high side of what the whole reference would show.
"""
from __future__ import annotations

import numpy as np
from scipy.stats import wasserstein_distance

from svcore.errors import StoreError
from svcore.seeds import stream_seed

from .realism import CORRELATION_STATS, OCTAVES, PIXEL_STATS, VARIATION_STATS
from .profile import Profile

OCTAVE_STAT = "slope_octaves"
#: statistic -> (label, unit, histogram range) in report order.
STATS: dict[str, tuple[str, str, tuple[float, float]]] = {
    "diffuse_luminance": ("diffuse luminance Y", "", (0.0, 1.0)),
    "diffuse_chroma": ("diffuse chroma C*ab", "CIELAB", (0.0, 80.0)),
    "specular_f0": ("specular F0 luminance", "", (0.0, 1.0)),
    "roughness": ("roughness", "", (0.0, 1.0)),
    "normal_tilt_deg": ("normal tilt", "deg", (0.0, 60.0)),
    "cv_diffuse": ("CV of diffuse Y in a material", "", (0.0, 1.5)),
    "cv_specular": ("CV of specular Y in a material", "", (0.0, 1.5)),
    "cv_roughness": ("CV of roughness in a material", "", (0.0, 1.5)),
    "cv_relief": ("CV of slope magnitude in a material", "", (0.0, 1.5)),
    "r_roughness_specular": ("r(roughness, specular Y) in a material", "", (-1.0, 1.0)),
    "r_diffuse_roughness": ("r(diffuse Y, roughness) in a material", "", (-1.0, 1.0)),
    "r_relief_diffuse": ("r(slope magnitude, diffuse Y) in a material", "", (-1.0, 1.0)),
    OCTAVE_STAT: ("slope power by octave", "L1 of shares", (0.0, 1.0)),
}
BINS = 32


def _values(p: Profile, stat: str) -> np.ndarray:
    return p.pixels[stat].ravel() if stat in PIXEL_STATS else p.per_material[stat]


def mean_octaves(p: Profile) -> np.ndarray:
    """(7,) mean octave shares over the materials that have relief (all-zero shares: a flat normal map)."""
    has = p.octaves.sum(1) > 0
    return p.octaves[has].mean(0) if has.any() else np.zeros(len(OCTAVES))


def distances(a: Profile, b: Profile) -> dict[str, float]:
    """statistic -> distance between two profiles (Wasserstein, or L1 for :data:`OCTAVE_STAT`)."""
    out = {k: float(wasserstein_distance(_values(a, k), _values(b, k)))
           for k in (*PIXEL_STATS, *VARIATION_STATS, *CORRELATION_STATS)}
    out[OCTAVE_STAT] = float(np.abs(mean_octaves(a) - mean_octaves(b)).sum())
    return out


def split_halves(n: int, splits: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """``splits`` random splits of n materials into two halves of n // 2 (an odd one out is left out), split s
    drawn from the named seed stream ``realism.split_half`` (seed, s): the same halves for the same seed."""
    if n < 2:
        raise StoreError(f"a reference needs at least 2 materials for a noise floor, it has {n}")
    out = []
    for s in range(splits):
        perm = np.random.default_rng(stream_seed(seed, "realism.split_half", s)).permutation(n)
        h = n // 2
        out.append((np.sort(perm[:h]), np.sort(perm[h:2 * h])))
    return out


def noise_floor(ref: Profile, splits: int = 8, seed: int = 0) -> dict[str, dict]:
    """statistic -> {"mean", "std", "values"}: the distance between the halves of each split of the reference."""
    per = [distances(ref.subset(a), ref.subset(b)) for a, b in split_halves(len(ref), splits, seed)]
    return {k: {"mean": float(np.mean([d[k] for d in per])), "std": float(np.std([d[k] for d in per])),
                "values": [d[k] for d in per]} for k in STATS}


def _describe(p: Profile) -> dict:
    return {"name": p.name, "kind": p.kind, "materials": len(p), "size": p.size}


def compare(stores: list[Profile], ref: Profile, splits: int = 8, seed: int = 0) -> dict:
    """The report of `svgen stats --reference`: every statistic's distance from each store to the reference with
    the reference's noise floor, the histograms and octave shares the chart draws, and per-statistic medians.

    Returns:
        {"reference", "stores", "splits", "seed", "octaves", "distances": {stat: {"label", "unit", "measure",
        "noise_floor", "noise_floor_std", "to_reference": {store: d}}}, "octave_shares": {name: (7,)},
        "histograms": {stat: {"range", "density": {name: (BINS,)}}}, "medians": {stat: {name: m}}}.
    """
    floor = noise_floor(ref, splits, seed)
    dist = {s.name: distances(s, ref) for s in stores}
    everyone = [ref, *stores]
    out = {"reference": _describe(ref), "stores": [_describe(s) for s in stores], "splits": splits, "seed": seed,
           "octaves": [list(o) for o in OCTAVES], "distances": {}, "histograms": {}, "medians": {},
           "octave_shares": {p.name: mean_octaves(p).tolist() for p in everyone}}
    for k, (label, unit, rng) in STATS.items():
        out["distances"][k] = {"label": label, "unit": unit,
                               "measure": "L1" if k == OCTAVE_STAT else "Wasserstein-1",
                               "noise_floor": floor[k]["mean"], "noise_floor_std": floor[k]["std"],
                               "to_reference": {name: d[k] for name, d in dist.items()}}
        if k == OCTAVE_STAT:
            continue
        out["histograms"][k] = {"range": list(rng), "density": {
            p.name: np.histogram(np.clip(_values(p, k), *rng), BINS, rng, density=True)[0].tolist()
            for p in everyone}}
        out["medians"][k] = {p.name: float(np.median(_values(p, k))) for p in everyone}
    return out


def table(report: dict) -> str:
    """Markdown: one row per statistic, each store's distance to the reference (and its multiple of the noise
    floor), the floor; then the mean octave shares of the reference and each store."""
    names = [s["name"] for s in report["stores"]]
    ref = report["reference"]
    lines = [f"distance to the reference {ref['name']} ({ref['kind']}, {ref['materials']} materials); noise floor: "
             f"the reference's halves, mean ± std of {report['splits']} splits (seed {report['seed']})", "",
             "| statistic | measure | " + " | ".join(names) + " | noise floor |",
             "|---|---|" + "---:|" * (len(names) + 1)]
    for d in report["distances"].values():
        floor = d["noise_floor"]
        cells = [f"{v:.3g} ({v / floor:.1f}×)" if floor > 0 else f"{v:.3g}" for v in d["to_reference"].values()]
        unit = f" ({d['unit']})" if d["unit"] else ""
        lines.append(f"| {d['label']}{unit} | {d['measure']} | " + " | ".join(cells)
                     + f" | {floor:.3g} ± {d['noise_floor_std']:.2g} |")
    other = [f"{s['name']} {s['size']}²" for s in report["stores"] if s["size"] != ref["size"]]
    if other:
        lines += ["", f"note: octave shares count cycles per map at each map's own size, and the reference is "
                      f"{ref['size']}² while {', '.join(other)}: compare stores at the reference's size"]
    lines += ["", "| share of slope power, cycles per map | "
              + " | ".join(f"{lo}–{hi}" for lo, hi in report["octaves"]) + " |",
              "|---|" + "---:|" * len(report["octaves"])]
    for name, shares in report["octave_shares"].items():
        tag = " (reference)" if name == ref["name"] else ""
        lines.append(f"| {name}{tag} | " + " | ".join(f"{x:.3f}" for x in shares) + " |")
    return "\n".join(lines)
