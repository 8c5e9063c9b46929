"""Plastic: a dielectric with moulded texture (stipple, leather-look cells or ribs), smudges and scratches.

Physical ranges (``PHYSICAL``): common plastics have refractive indices 1.45-1.6 (PMMA 1.49, ABS 1.54, PS 1.59),
so F0 = ((n - 1) / (n + 1))^2 is 0.034-0.053 (physicallybased.info lists plastic F0 0.04-0.05), and one part has
one F0 everywhere; pigmented plastic albedo spans carbon-black ~0.02-0.03 to white ~0.85 (physicallybased.info
measured albedos). Roughness covers polished acrylic to matte textured mouldings.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_params, slope_scaled, tint
from ..noise import Tex, band_field, blur, smoothstep
from ..patterns import scratches, worley
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.02, 0.88), "specular": (0.03, 0.06), "roughness": (0.02, 1.0)}

PARAMS = [
    *rgb_params("color", (0.2, 0.4, 0.8), "plastic colour"),
    P("roughness", 0.3, 0.02, 0.9, "mean roughness"),
    P("specular", 0.045, 0.034, 0.053, "F0 (one polymer: uniform over the part)"),
    P("grain", 0.3, 0.0, 1.0, "depth of the moulded stipple texture"),
    P("grain_scale", 0.03, 0.015, 0.1, "stipple size (texture widths)"),
    P("grain_rough", 0.1, 0.0, 0.4, "extra roughness on stipple peaks"),
    P("cells", 0, 0, 40, "leather-look moulded cells across the texture (0: none)", "int"),
    P("ribs", 0, 0, 32, "moulded parallel ribs across the texture (0: none)", "int"),
    P("smudge", 0.1, 0.0, 1.0, "greasy smudges (lower roughness blotches)"),
    P("scratch_count", 0.0, 0.0, 300.0, "number of scratches", "int"),
    P("scratch_depth", 0.5, 0.0, 1.0, "scratch depth and whiteness"),
    P("scratch_angle", 0.5, 0.0, 1.5708, "main scratch direction (rad)"),
    P("color_var", 0.03, 0.0, 0.4, "colour unevenness"),
    P("translucency", 0.0, 0.0, 1.0, "milky lightening of the colour (subsurface look)"),
]


@register_class("plastic", PARAMS)
def plastic(p: dict, size: int, rng: np.random.Generator):
    """Moulded plastic."""
    tex = Tex(size, rng)
    base = color_param(p, "color")
    # stipple: one octave of bumps about grain_scale across (mid scales: 4-27 cycles per map)
    g = band_field(size, tex.seed(), 0.4 / p["grain_scale"], 0.35)
    sm, unev = tex.fbm2(0.2, beta=3.2)
    sc = scratches(tex, p["scratch_count"], 0.15, p["scratch_angle"], 0.4, width=0.003)
    nc = int(round(p["cells"]))
    f1, f2, _, _ = worley(tex, max(nc, 1), 0.9, enabled=nc > 0)
    nr = int(round(p["ribs"]))
    col = tint(base, unev, p["color_var"])
    col = lerp(col, np.minimum(1, base * 0.6 + 0.3), np.full(col.shape[:2], 0.5 * p["translucency"], np.float32))
    sd = sc * p["scratch_depth"]
    h = slope_scaled(g, 0.08 * p["grain"] + 1e-6) - 0.0008 * sd
    if nc > 0:  # rounded cells with soft valleys between them, as a grained mould leaves them
        cellh = smoothstep(0.0, 0.5, f2 - f1)
        h = h + slope_scaled(blur(cellh, 0.003), 0.12)
    if nr > 0:  # rounded ribs: a raised cosine across v
        h = h + slope_scaled(np.cos(2 * np.pi * nr * tex.v) ** 2, 0.15)
    diff = lerp(col, np.minimum(1, col + 0.25), sd * 0.7)
    r = p["roughness"] + p["grain_rough"] * np.clip(g, 0, None) * 0.5 - 0.25 * p["smudge"] * np.clip(sm, 0, None)
    r = r + 0.35 * sd
    return finish(h, 1.0, diff, p["specular"], np.clip(r, 0.02, 1), albedo=PHYSICAL["diffuse"])


register_preset("plastic/glossy_blue", "plastic", {
    **rgb("color", (0.2, 0.38, 0.7), (-0.12, 0.12)),
    "roughness": (0.1, 0.03, 0.25), "smudge": (0.2, 0.0, 0.6), "scratch_count": (60, 10, 200),
    "scratch_depth": (0.4, 0.1, 0.8)}, fixed={"grain": 0.05})
register_preset("plastic/textured_black", "plastic", {
    **rgb("color", (0.08, 0.08, 0.08), (-0.04, 0.1)),
    "roughness": (0.45, 0.3, 0.7), "grain": (0.6, 0.3, 1.0), "grain_scale": (0.03, 0.02, 0.05),
    "grain_rough": (0.15, 0.0, 0.4), "scratch_count": (30, 0, 120)})
register_preset("plastic/toy_yellow", "plastic", {
    **rgb("color", (0.86, 0.7, 0.28), (-0.15, 0.08)),
    "roughness": (0.2, 0.05, 0.4), "color_var": (0.05, 0.0, 0.2), "smudge": (0.3, 0.0, 0.8),
    "translucency": (0.1, 0.0, 0.4)}, fixed={"grain": 0.1})
register_preset("plastic/milky_white", "plastic", {
    **rgb("color", (0.85, 0.85, 0.82), (-0.1, 0.1)),
    "translucency": (0.5, 0.2, 0.9), "roughness": (0.3, 0.15, 0.5), "grain": (0.2, 0.0, 0.5),
    "grain_scale": (0.04, 0.02, 0.07), "smudge": (0.2, 0.0, 0.6)})
register_preset("plastic/scratched_red", "plastic", {
    **rgb("color", (0.65, 0.12, 0.1), (-0.15, 0.12)),
    "scratch_count": (180, 80, 300), "scratch_depth": (0.6, 0.3, 1.0), "scratch_angle": (0.3, 0.0, 1.57),
    "roughness": (0.25, 0.1, 0.5), "grain": (0.2, 0.0, 0.6), "color_var": (0.08, 0.0, 0.3),
    "specular": (0.045, 0.036, 0.053)})
# car-interior moulding: a leather-look cellular grain under a fine stipple, satin
register_preset("plastic/dashboard_grain", "plastic", {
    **rgb("color", (0.16, 0.16, 0.17), (-0.06, 0.12)),
    "cells": (24, 14, 36), "grain": (0.3, 0.1, 0.6), "roughness": (0.5, 0.35, 0.7), "grain_rough": (0.1, 0.0, 0.3),
    "smudge": (0.2, 0.0, 0.5)}, fixed={"grain_scale": 0.02})
# a ribbed moulding (appliance panel, crate side): parallel rounded ribs, semi-gloss
register_preset("plastic/ribbed_grey", "plastic", {
    **rgb("color", (0.55, 0.56, 0.56), (-0.25, 0.2)),
    "ribs": (12, 6, 24), "roughness": (0.3, 0.15, 0.5), "scratch_count": (40, 0, 120), "grain": (0.2, 0.0, 0.5),
    "color_var": (0.05, 0.0, 0.2)})
