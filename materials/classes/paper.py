"""Paper and board: office, kraft, newsprint, watercolour, coated, crumpled, cardboard and corrugated flutes.

Cellulose is a dielectric (refractive index about 1.47-1.55: F0 0.035-0.05; coated stock up to 0.06); paper
albedos run from about 0.04 (black card) to 0.85 (bright office paper) in the physicallybased.info measured
albedo tables, and roughness from matte uncoated (0.8-1) to coated gloss (about 0.3). Relief: cockle (a few
cycles), watercolour tooth and flutes (8-32 cycles) carry the slope power; fibres are a fine minority.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, rgb, rgb_params, tint
from ..heights import at_slope, band_pair, bands
from ..noise import F32, Tex, fbm_pair, smoothstep
from ..patterns import scratches, worley
from ..registry import register_class, register_preset

#: linear diffuse, F0 and roughness that every variant keeps (module docstring: sources).
PHYSICAL = {"diffuse": (0.03, 0.9), "specular": (0.03, 0.065), "roughness": (0.25, 1.0)}

PARAMS = [
    *rgb_params("color", (0.88, 0.87, 0.84), "paper colour"),
    P("cockle", 0.03, 0.0, 0.1, "RMS slope of the cockle (large, soft waves)"),
    P("tooth", 0.0, 0.0, 0.12, "RMS slope of the surface tooth (watercolour grain)"),
    P("tooth_cycles", 24, 12, 40, "tooth bumps across the texture"),
    P("fibres", 0.3, 0.0, 1.0, "visible fibres (colour streaks and fine relief)"),
    P("strands", 0.0, 0.0, 1.0, "long loose fibre strands (washi, recycled board)"),
    P("crumple", 0.0, 0.0, 0.25, "RMS slope of crumple facets and creases"),
    P("crumple_cells", 8, 4, 16, "crumple facets across the texture", "int"),
    P("flutes", 0, 0, 24, "corrugation flutes across the texture (0 none)", "int"),
    P("flute_slope", 0.0, 0.0, 0.5, "RMS slope of the flutes (small: a liner over them; large: bare flutes)"),
    P("flecks", 0.0, 0.0, 1.0, "dark inclusions (recycled stock)"),
    P("color_var", 0.06, 0.0, 0.3, "mottling of the colour"),
    # calibrated (#23): reference Paper001 (materials-cc0): mean roughness 0.63; matte papers a little rougher,
    # coated ones smoother
    P("roughness", 0.72, 0.3, 1.0, "roughness"),
    P("coating", 0.0, 0.0, 1.0, "clay coating: smoother, a little more F0, smoother relief"),
]


@register_class("paper", PARAMS)
def paper(p: dict, size: int, rng: np.random.Generator):
    """Paper and board."""
    tex = Tex(size, rng)
    base = color_param(p, "color")
    coat = p["coating"]
    h = bands(tex, 4.0, p["cockle"], 0.0)
    s_tooth, s_fib, s_mot = tex.seed(), tex.seed(), tex.seed()
    tooth, fl = band_pair(size, s_tooth, p["tooth_cycles"], 20.0)
    fib, fib2 = fbm_pair(size, s_fib, 0.05, 1.4, aniso=3.0, angle=0.4, detail=0.8 / size)
    mot, mot2 = fbm_pair(size, s_mot, 0.25, 3.0)
    st = scratches(tex, 60 * p["strands"], 0.15, 0.0, 3.0, width=0.8 / size)
    f1, f2, cell, rnd = worley(tex, p["crumple_cells"], 0.9, enabled=p["crumple"] > 0)

    if p["tooth"] > 0:  # tooth: rounded bumps, the tops of a band field
        h = h + at_slope(np.maximum(tooth, -0.5), p["tooth"] * (1 - 0.5 * coat))
    if p["crumple"] > 0:  # facets tilted away from creases; a random sign per cell makes ridges and valleys
        sgn = np.where(rnd[cell] > 0.5, 1.0, -1.0).astype(F32)
        h = h + at_slope(sgn * (f2 - f1) / max(p["crumple_cells"], 1), p["crumple"])
    n = int(round(p["flutes"]))
    if n > 0 and p["flute_slope"] > 0:
        h = h + at_slope(np.sin(2 * np.pi * (tex.u * n + 0.25)).astype(F32), p["flute_slope"])
    # fibres: mostly colour; their relief is the fine minority
    h = h + at_slope(fib, 0.012 * p["fibres"] * (1 - 0.7 * coat)) + 0.002 * p["strands"] * st
    col = tint(base, mot + 0.5 * mot2, p["color_var"])
    col = col * (1 + 0.05 * p["fibres"] * fib)[..., None]
    col = col * (1 + 0.12 * st * p["strands"])[..., None]
    if n > 0:  # flute valleys are shaded by glue and the liner's shadow
        col = col * (1 - 0.25 * min(1.0, 4 * p["flute_slope"]) * smoothstep(0.3, 1.0, -np.sin(2 * np.pi * (tex.u * n + 0.25))))[..., None]
    dots = smoothstep(1.2, 2.0, fl) * p["flecks"]  # sparse specks: the rare peaks of a band field
    col = col * (1 - 0.8 * dots)[..., None]
    r = p["roughness"] * (1 - 0.55 * coat) + 0.04 * fib2 * (1 - coat)
    spec = 0.04 + 0.02 * coat
    return finish(h, 1.0, np.clip(col, 0.03, 0.9), np.full(3, spec, F32), np.clip(r, 0.25, 1.0))


register_preset("paper/office_white", "paper", {
    **rgb("color", (0.92, 0.92, 0.9), (-0.06, 0.03)), "cockle": (0.03, 0.0, 0.07), "fibres": (0.3, 0.1, 0.6),
    "roughness": (0.68, 0.55, 0.85)})
register_preset("paper/kraft_brown", "paper", {
    **rgb("color", (0.68, 0.52, 0.36), (-0.12, 0.08)), "fibres": (0.6, 0.3, 1.0), "flecks": (0.3, 0.0, 0.7),
    "color_var": (0.08, 0.02, 0.2), "cockle": (0.04, 0.01, 0.08), "roughness": (0.7, 0.55, 0.88)})
register_preset("paper/newsprint", "paper", {
    **rgb("color", (0.78, 0.76, 0.7), (-0.1, 0.05)), "fibres": (0.5, 0.2, 0.9), "flecks": (0.4, 0.1, 0.8),
    "color_var": (0.05, 0.01, 0.12), "cockle": (0.05, 0.02, 0.09)})
register_preset("paper/crumpled_white", "paper", {
    **rgb("color", (0.9, 0.9, 0.88), (-0.08, 0.04)), "crumple": (0.14, 0.06, 0.25), "crumple_cells": (8, 5, 14),
    "fibres": (0.3, 0.1, 0.6)})
register_preset("paper/crumpled_kraft", "paper", {
    **rgb("color", (0.62, 0.46, 0.3), (-0.1, 0.08)), "crumple": (0.16, 0.08, 0.25), "crumple_cells": (6, 4, 10),
    "fibres": (0.6, 0.3, 1.0), "flecks": (0.2, 0.0, 0.5)})
register_preset("paper/watercolour_cold_press", "paper", {
    **rgb("color", (0.93, 0.91, 0.85), (-0.06, 0.04)), "tooth": (0.07, 0.04, 0.12), "tooth_cycles": (20, 14, 32),
    "cockle": (0.04, 0.0, 0.08), "roughness": (0.8, 0.65, 0.95)})
register_preset("paper/cardboard_liner", "paper", {
    **rgb("color", (0.6, 0.45, 0.3), (-0.12, 0.08)), "flutes": (8, 5, 12), "flute_slope": (0.04, 0.015, 0.08),
    "fibres": (0.5, 0.2, 0.9), "flecks": (0.2, 0.0, 0.5), "color_var": (0.08, 0.02, 0.18)})
register_preset("paper/corrugated_flutes", "paper", {
    **rgb("color", (0.58, 0.43, 0.28), (-0.12, 0.08)), "flutes": (12, 8, 20), "flute_slope": (0.3, 0.18, 0.45),
    "fibres": (0.5, 0.2, 0.9), "roughness": (0.75, 0.6, 0.9)})
register_preset("paper/coated_gloss", "paper", {
    **rgb("color", (0.9, 0.9, 0.9), (-0.1, 0.05)), "coating": (0.85, 0.6, 1.0), "roughness": (0.55, 0.4, 0.8),
    "cockle": (0.015, 0.0, 0.04)}, fixed={"fibres": 0.1})
register_preset("paper/recycled_grey_board", "paper", {
    **rgb("color", (0.45, 0.44, 0.42), (-0.15, 0.1)), "flecks": (0.6, 0.3, 1.0), "strands": (0.4, 0.1, 0.8),
    "fibres": (0.7, 0.4, 1.0), "color_var": (0.1, 0.03, 0.2), "tooth": (0.03, 0.0, 0.06)})
register_preset("paper/parchment_aged", "paper", {
    **rgb("color", (0.82, 0.72, 0.52), (-0.12, 0.06)), "color_var": (0.2, 0.1, 0.3), "cockle": (0.06, 0.03, 0.1),
    "roughness": (0.7, 0.5, 0.85), "fibres": (0.4, 0.1, 0.8)}, fixed={"coating": 0.2})
register_preset("paper/washi_strands", "paper", {
    **rgb("color", (0.9, 0.88, 0.82), (-0.08, 0.05)), "strands": (0.7, 0.4, 1.0), "fibres": (0.6, 0.3, 1.0),
    "cockle": (0.04, 0.01, 0.08), "roughness": (0.75, 0.6, 0.9)})
register_preset("paper/black_card", "paper", {
    **rgb("color", (0.22, 0.22, 0.22), (-0.02, 0.1)), "tooth": (0.03, 0.0, 0.06), "fibres": (0.3, 0.1, 0.6),
    "roughness": (0.7, 0.55, 0.85)})
