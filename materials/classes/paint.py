"""Paint: a coloured dielectric coat with orange peel, brush strokes, craquelure, chips down to a substrate, dirt.

Physical ranges (``PHYSICAL``): linear diffuse albedo of paints spans about 0.03 (matte black) to 0.85 (titanium
white), physicallybased.info's measured albedos ("White paint" ~0.8, charcoal/black ~0.02-0.04); a paint's clear
binder is a dielectric of F0 ~0.04-0.05 (IOR 1.5), except for the aluminium flakes of metallic car paint, which
reflect like the metal (up to ~0.25 in the few pixels they cover at the default amount). Roughness covers mirror
lacquer to chalky matte. The reference store's painted materials (svgen stats against materials-cc0) sit inside.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_fixed, rgb_params, slope_scaled, tint
from ..noise import Tex, band_field, blur, smoothstep
from ..patterns import worley
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.02, 0.88), "specular": (0.02, 0.25), "roughness": (0.02, 1.0)}

PARAMS = [
    *rgb_params("color", (0.7, 0.1, 0.1), "paint colour"),
    *rgb_params("substrate", (0.55, 0.55, 0.55), "colour under chipped paint"),
    P("roughness", 0.25, 0.02, 0.9, "mean roughness of the coat"),
    P("rough_var", 0.1, 0.0, 0.5, "roughness variation (smudges)"),
    P("specular", 0.045, 0.03, 0.06, "F0 of the coat (uniform: one binder)"),
    P("orange_peel", 0.3, 0.0, 1.0, "bumpiness of sprayed or rolled paint"),
    P("peel_scale", 0.04, 0.015, 0.12, "orange-peel / roller-stipple feature size (texture widths)"),
    P("brush", 0.0, 0.0, 1.0, "depth of brush strokes"),
    P("brush_angle", 0.0, 0.0, 1.5708, "brush direction (rad; half a turn is the same brushing)"),
    P("cracks", 0.0, 0.0, 1.0, "craquelure of old paint (cracks with curled-up edges)"),
    P("crack_cells", 10, 4, 24, "crack polygons across the texture", "int"),
    P("chips", 0.0, 0.0, 1.0, "area chipped off"),
    P("chip_scale", 0.15, 0.03, 0.5, "chip size (texture widths)"),
    P("dirt", 0.0, 0.0, 1.0, "darkening dirt in blotches"),
    P("color_var", 0.05, 0.0, 0.5, "low-frequency colour unevenness"),
    P("flakes", 0.0, 0.0, 1.0, "metallic flakes (sparkling specular)"),
]


@register_class("paint", PARAMS)
def paint(p: dict, size: int, rng: np.random.Generator):
    """Painted surface."""
    tex = Tex(size, rng)
    base = color_param(p, "color")
    sub = color_param(p, "substrate")
    # orange peel / roller stipple: one octave of bumps about peel_scale across (0.4 / peel_scale cycles, whose
    # slopes peak ~1.3x higher): mid-scale relief, 3-27 cycles per map
    peel = band_field(size, tex.seed(), 0.4 / p["peel_scale"], 0.35)
    # brush strokes: long along the stroke (~3 cycles), ridged across it (~25 cycles)
    brush = tex.fbm(0.12, beta=3.6, aniso=3.0, angle=p["brush_angle"], detail=0.03)
    chipf = tex.fbm(p["chip_scale"], beta=3.6)
    dirt, unev = tex.fbm2(0.35, beta=3.0)
    fl, fine = tex.fbm2(0.004, beta=0.0)
    smudge = tex.blobs(0.12)
    f1, f2, cid, crnd = worley(tex, p["crack_cells"], 0.9, enabled=p["cracks"] > 0)

    thr = 2.6 - 3.6 * p["chips"]  # chips=0: none; 1: ~84% of the area
    # the tail of a Gaussian field is never empty: fade chips out entirely as chips -> 0
    chip = smoothstep(thr - 0.04, thr + 0.04, chipf) * min(1.0, 20.0 * p["chips"])
    cw = 1.0 / max(p["crack_cells"], 1)
    d = (f2 - f1) * cw  # distance to the crack line, texture widths
    crack = (1 - smoothstep(0.0, 0.008, d)) * p["cracks"]
    curl = smoothstep(0.4 * cw, 0.0, d) ** 2 * p["cracks"]  # flakes curl up towards their cracks
    # the chip's wall in the height is wider than its colour edge: a sanded-off feathered edge, not a 1 px cliff
    chip_h = blur(smoothstep(thr - 0.5, thr + 0.5, chipf), 0.006) * min(1.0, 20.0 * p["chips"]) if p["chips"] > 0 else 0.0
    h = (slope_scaled(peel, 0.07 * p["orange_peel"] + 1e-6) + slope_scaled(brush, 0.09 * p["brush"] + 1e-6)
         + slope_scaled(blur(fine, 0.002), 0.02) - 0.003 * chip_h - 0.001 * crack + 0.004 * cw * 10 * curl)
    col = tint(base, unev + 0.3 * (crnd[cid] - 0.5) * p["cracks"], p["color_var"])
    dmask = np.clip(dirt * 0.5 + 0.2, 0, 1) * p["dirt"]
    dmask = np.clip(dmask + 0.8 * crack, 0, 1)  # dirt collects in the cracks
    diff = lerp(col, sub, chip) * (1 - 0.7 * dmask)[..., None]
    sparkle = np.clip(3.0 * (fl - 1.4), 0, None) * p["flakes"]
    spec = lerp(np.full(3, p["specular"], np.float32), 0.5 * base + 0.1, np.clip(sparkle, 0, 1))
    spec = lerp(spec, np.full(3, 0.04, np.float32), chip)
    r = p["roughness"] + p["rough_var"] * 0.5 * smudge + 0.3 * dmask
    r = lerp(r[..., None], np.full(1, 0.7, np.float32), chip)[..., 0]
    return finish(h, 1.0, diff, spec, np.clip(r, 0.02, 1), albedo=PHYSICAL["diffuse"])


register_preset("paint/glossy_red", "paint", {
    **rgb("color", (0.68, 0.1, 0.08), (-0.15, 0.12)),
    "roughness": (0.12, 0.05, 0.3), "orange_peel": (0.4, 0.1, 1.0), "peel_scale": (0.04, 0.025, 0.07),
    "rough_var": (0.1, 0.0, 0.3)})
register_preset("paint/chipped_blue", "paint", {
    **rgb("color", (0.2, 0.32, 0.55), (-0.12, 0.12)),
    "chips": (0.35, 0.15, 0.6), "chip_scale": (0.12, 0.05, 0.3), "roughness": (0.35, 0.2, 0.6),
    **rgb("substrate", (0.45, 0.42, 0.4), (-0.2, 0.2)), "dirt": (0.3, 0.0, 0.7), "orange_peel": (0.3, 0.0, 0.6)})
register_preset("paint/brushed_white", "paint", {
    **rgb("color", (0.88, 0.87, 0.83), (-0.1, 0.08)),
    "brush": (0.6, 0.3, 1.0), "brush_angle": (0.0, 0.0, 1.57), "roughness": (0.4, 0.2, 0.7),
    "color_var": (0.05, 0.0, 0.2), "dirt": (0.1, 0.0, 0.5)}, fixed={"orange_peel": 0.1})
register_preset("paint/metallic_car", "paint", {
    **rgb("color", (0.12, 0.32, 0.22), (-0.1, 0.2)),
    "flakes": (0.6, 0.2, 1.0), "roughness": (0.15, 0.05, 0.3), "orange_peel": (0.3, 0.05, 0.8),
    "specular": (0.05, 0.04, 0.06)})
register_preset("paint/matte_wall", "paint", {
    **rgb("color", (0.8, 0.75, 0.62), (-0.3, 0.12)),
    "roughness": (0.75, 0.5, 0.9), "orange_peel": (0.6, 0.3, 1.0), "peel_scale": (0.03, 0.02, 0.05),
    "color_var": (0.1, 0.0, 0.3), "dirt": (0.2, 0.0, 0.6), "rough_var": (0.1, 0.0, 0.4)})
register_preset("paint/peeling_green", "paint", {
    **rgb("color", (0.25, 0.42, 0.3), (-0.12, 0.12)),
    "chips": (0.6, 0.4, 0.8), "chip_scale": (0.2, 0.1, 0.4),
    "brush": (0.5, 0.2, 1.0), "roughness": (0.5, 0.3, 0.8), "dirt": (0.4, 0.1, 0.8),
    "color_var": (0.15, 0.0, 0.4)}, fixed=rgb_fixed("substrate", (0.45, 0.33, 0.22)))
# craquelure: old oil or lead paint split into polygons whose edges curl up, dirt in the cracks
register_preset("paint/cracked_old", "paint", {
    **rgb("color", (0.78, 0.76, 0.68), (-0.25, 0.1)),
    "cracks": (0.8, 0.5, 1.0), "crack_cells": (12, 6, 20), "roughness": (0.55, 0.35, 0.8),
    "dirt": (0.3, 0.1, 0.6), "color_var": (0.1, 0.0, 0.3), "brush": (0.3, 0.0, 0.6)},
    fixed={"orange_peel": 0.1})
# rolled emulsion on a wall: a coarse stipple left by the roller nap, matte
register_preset("paint/roller_stipple", "paint", {
    **rgb("color", (0.62, 0.64, 0.63), (-0.3, 0.2)),
    "orange_peel": (0.9, 0.6, 1.0), "peel_scale": (0.07, 0.05, 0.1), "roughness": (0.8, 0.65, 0.9),
    "color_var": (0.05, 0.0, 0.15), "dirt": (0.1, 0.0, 0.4)}, fixed={"rough_var": 0.05})
