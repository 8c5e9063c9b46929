"""Ground: soil, sand, gravel, dried mud, forest floor; very rough, low specular.

Physical ranges (``PHYSICAL``): soils and sands are dielectric mineral/organic mixtures, F0 0.02-0.08 (quartz and
calcite 0.04-0.05, a water film 0.02; the wet patches shine by their lower roughness); linear albedo from wet dark
soil ~0.02 to dry light sand ~0.75 (physicallybased.info's measured albedos: soil 0.03-0.3, desert sand ~0.4-0.6;
the ground scans of materials-cc0); roughness at least 0.1 (no ground is polished).
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_params, tint
from ..noise import Tex, smoothstep
from ..patterns import scratches, worley
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.02, 0.75), "specular": (0.02, 0.08), "roughness": (0.1, 1.0)}

PARAMS = [
    *rgb_params("soil", (0.35, 0.25, 0.17), "soil colour"),
    *rgb_params("pebble", (0.55, 0.52, 0.48), "pebble colour"),
    P("bump", 0.5, 0.0, 1.0, "soil relief"),
    P("bump_scale", 0.1, 0.02, 0.4, "relief feature size (texture widths)"),
    P("pebbles", 0.0, 0.0, 1.0, "area covered by pebbles"),
    P("pebble_count", 20, 6, 60, "pebbles across the texture", "int"),
    P("cracks", 0.0, 0.0, 1.0, "dried-mud cracks"),
    P("crack_cells", 6, 2, 16, "crack polygons across the texture", "int"),
    P("ripples", 0.0, 0.0, 1.0, "wind ripples (sand)"),
    P("moisture", 0.0, 0.0, 1.0, "wet patches (darker, smoother)"),
    P("debris", 0.0, 0.0, 1.0, "twigs and needles"),
    P("color_var", 0.2, 0.0, 0.6, "colour variation"),
    # calibrated (#23): reference ground scans (materials-cc0, experiments/library_stats/results/stats_by_class.json): mean
    # roughness 0.53-0.85, 0.69 over the five
    P("roughness", 0.75, 0.45, 1.0, "roughness of dry soil"),
]


@register_class("ground", PARAMS)
def ground(p: dict, size: int, rng: np.random.Generator):
    """Natural ground."""
    tex = Tex(size, rng)
    soil, peb = color_param(p, "soil"), color_param(p, "pebble")
    b1, b2 = tex.fbm2(p["bump_scale"], beta=2.6)
    pf1, pf2, pid, prnd = worley(tex, p["pebble_count"], 1.0, enabled=p["pebbles"] > 0)
    cf1, cf2, _, _ = worley(tex, p["crack_cells"], 0.9, enabled=p["cracks"] > 0)
    rip = tex.fbm(0.3, beta=3.0, aniso=6.0, angle=0.2)
    wet, cv = tex.fbm2(0.3, beta=3.2)
    dbr = scratches(tex, 120, 0.06, 1.0, 1.5, width=0.6 / 256)

    ps = 1.0 / max(p["pebble_count"], 1)
    pr = 0.45  # pebble radius in cell widths; `pebbles` is the fraction of cells holding one
    pebm = smoothstep(pr, pr - 0.08, pf1) * (prnd[pid] < p["pebbles"])
    pebh = np.sqrt(np.clip(1 - (pf1 / pr) ** 2, 0, 1)) * ps * 0.5 * pebm
    crack = (1 - smoothstep(0.0, 0.06, cf2 - cf1)) * p["cracks"]
    ripple = np.sin(2 * np.pi * (tex.u * 24 + tex.v * 5 + 0.8 * rip)) * p["ripples"]
    h = 0.003 * p["bump"] * p["bump_scale"] * 10 * b1 + pebh - 0.004 * crack + 0.0015 * ripple
    debm = np.clip(2.5 * dbr, 0, 1) * p["debris"]
    h = h + 0.001 * debm
    col = tint(soil, cv + 0.5 * b2, p["color_var"] * 0.8)
    col = col * (1 - 0.6 * crack)[..., None]
    col = lerp(col, tint(peb, (prnd[pid] - 0.5) * np.ones_like(pf1), 0.6), pebm)
    col = lerp(col, np.array([0.18, 0.11, 0.05], np.float32), debm)
    wm = smoothstep(0.0, 0.5, wet + 1.2 * p["moisture"] - 1.0) * min(1.0, 20 * p["moisture"])
    col = col * (1 - 0.45 * wm)[..., None]
    r = p["roughness"] - 0.45 * wm - 0.2 * pebm + 0.05 * b2
    # calibrated (#23): dry mineral grains have F0 ~0.04 (quartz, calcite; every reference ground scan 0.040); a
    # water film (n 1.33) has F0 0.02, so wet patches go toward it: they shine by their lower roughness, not by F0
    spec = np.clip(0.04 - 0.015 * wm + 0.006 * b2, *PHYSICAL["specular"])
    return finish(h, 1.0, col, spec[..., None], np.clip(r, *PHYSICAL["roughness"]), albedo=PHYSICAL["diffuse"])


register_preset("ground/dry_soil", "ground", {
    **rgb("soil", (0.45, 0.33, 0.22), (-0.15, 0.15)),
    "bump": (0.6, 0.3, 1.0), "bump_scale": (0.08, 0.03, 0.2), "color_var": (0.25, 0.1, 0.5), "pebbles": (0.15, 0.0, 0.4),
    "roughness": (0.78, 0.65, 0.92)})
register_preset("ground/gravel", "ground", {
    **rgb("pebble", (0.55, 0.53, 0.5), (-0.2, 0.2)), **rgb("soil", (0.3, 0.27, 0.23), (-0.1, 0.1)),
    "pebbles": (0.8, 0.5, 1.0), "pebble_count": (16, 8, 30), "bump": (0.4, 0.1, 0.8)})
register_preset("ground/cracked_mud", "ground", {
    **rgb("soil", (0.55, 0.42, 0.3), (-0.15, 0.1)),
    "cracks": (0.9, 0.5, 1.0), "crack_cells": (6, 3, 12), "bump": (0.3, 0.1, 0.7), "color_var": (0.15, 0.0, 0.4),
    "moisture": (0.1, 0.0, 0.5)})
register_preset("ground/beach_sand", "ground", {
    **rgb("soil", (0.85, 0.75, 0.55), (-0.15, 0.1)),
    "ripples": (0.7, 0.3, 1.0), "bump": (0.3, 0.1, 0.6), "bump_scale": (0.03, 0.02, 0.08), "moisture": (0.2, 0.0, 0.7),
    "pebbles": (0.05, 0.0, 0.3)}, fixed={"color_var": 0.1})
register_preset("ground/forest_floor", "ground", {
    **rgb("soil", (0.2, 0.13, 0.08), (-0.1, 0.1)),
    "debris": (0.7, 0.3, 1.0), "moisture": (0.4, 0.1, 0.8), "bump": (0.6, 0.3, 1.0), "color_var": (0.3, 0.1, 0.6),
    "pebbles": (0.1, 0.0, 0.3)})
register_preset("ground/wet_mud", "ground", {
    **rgb("soil", (0.28, 0.2, 0.13), (-0.1, 0.1)),
    "moisture": (0.8, 0.5, 1.0), "bump": (0.7, 0.4, 1.0), "bump_scale": (0.15, 0.05, 0.3),
    "roughness": (0.72, 0.55, 0.88),
    "pebbles": (0.1, 0.0, 0.3)})
