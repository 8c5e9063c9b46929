"""Cork: agglomerated granules (boards, tiles, stoppers, expanded black cork) and natural bark-cork slabs.

Cork is a dielectric (suberin and lignin, F0 about 0.04; waxed or varnished up to 0.05-0.06). Albedos: tan to
brown, 0.03 (roasted expanded cork) to about 0.5 (pale pinboard), in line with the wood and bark albedos of the
physicallybased.info measured tables and the wood scans of the reference set; roughness from matte raw cork (0.8-1)
to sealed floor tiles (about 0.3). Relief: granule domes (12-48 across the texture) and board undulation at mid
scales; gaps between granules and pores are darker, little deeper.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_fixed, rgb_params, tint
from ..heights import at_slope, band_pair, bands
from ..noise import F32, Tex, fbm_pair, smoothstep
from ..patterns import worley
from ..registry import register_class, register_preset

#: linear diffuse, F0 and roughness that every variant keeps (module docstring: sources).
PHYSICAL = {"diffuse": (0.02, 0.6), "specular": (0.03, 0.065), "roughness": (0.2, 1.0)}

PARAMS = [
    *rgb_params("color", (0.72, 0.52, 0.34), "granule colour"),
    *rgb_params("dark", (0.3, 0.18, 0.1), "colour of dark granules and gaps"),
    P("granules", 24, 8, 48, "granules across the texture", "int"),
    P("stretch", 1.0, 1.0, 3.0, "granules elongated across (natural cork slabs)"),
    P("granule_var", 0.25, 0.0, 0.6, "shade difference between granules"),
    P("dark_frac", 0.1, 0.0, 0.6, "share of dark granules"),
    P("gaps", 0.5, 0.0, 1.0, "darkness and depth of the gaps between granules"),
    P("relief", 0.06, 0.0, 0.15, "RMS slope of the granule domes"),
    P("pores", 0.3, 0.0, 1.0, "dark pores (lenticels) in the granules"),
    P("undulation", 0.02, 0.0, 0.06, "RMS slope of the board's soft waves"),
    P("color_var", 0.08, 0.0, 0.3, "large-scale colour mottling"),
    # calibrated (#23): no cork in the reference: between its paper (0.63) and its fabric (0.81), raw cork being
    # a matte cellular solid
    P("roughness", 0.75, 0.4, 1.0, "roughness of the raw cork"),
    P("seal", 0.0, 0.0, 1.0, "wax or varnish: smoother, shinier, relief filled"),
]


@register_class("cork", PARAMS)
def cork(p: dict, size: int, rng: np.random.Generator):
    """Cork."""
    tex = Tex(size, rng)
    light, dark = color_param(p, "color"), color_param(p, "dark")
    seal = p["seal"]
    n = int(round(p["granules"]))
    # aspect < 1: fewer rows than columns, granules stretched along u
    f1, f2, cell, rnd = worley(tex, n, 1.0, aspect=1.0 / p["stretch"])
    und = bands(tex, 4.0, p["undulation"] * (1 - 0.6 * seal), 0.0)
    pore, pore2 = band_pair(size, tex.seed(), 2.0 * n, 3.0 * n)
    mot, mot2 = fbm_pair(size, tex.seed(), 0.3, 3.0)

    g = rnd[cell]
    edge = f2 - f1  # 0 on a granule boundary
    gap = smoothstep(0.12, 0.0, edge) * p["gaps"]
    # a broad rounded rise from the boundary (half a granule wide): the relief sits at the granule scale,
    # not in the one-pixel gap lines (those only darken)
    domeh = smoothstep(0.0, 0.6, edge) * (0.6 + 0.8 * g) * (0.5 + 0.5 * p["gaps"])
    h = at_slope(domeh.astype(F32), p["relief"] * (1 - 0.7 * seal)) + und
    pm = smoothstep(1.3, 2.2, pore + 0.5 * pore2) * p["pores"]  # pores: colour only (sub-8-px relief)
    isdark = (g < p["dark_frac"]).astype(F32)
    shade = (g - 0.5) * 2.0
    col = tint(lerp(light, dark, isdark), shade + 0.5 * mot, p["granule_var"])
    col = tint(col, mot2, p["color_var"])
    col = lerp(col, dark * 0.6, np.clip(gap + 0.8 * pm, 0, 1))
    col = col * (1 - 0.15 * seal)  # a wet-look coat darkens the albedo a little
    r = p["roughness"] * (1 - 0.6 * seal) + 0.1 * gap + 0.03 * mot
    spec = np.full(3, 0.04 + 0.015 * seal, F32)
    return finish(h, 1.0, np.clip(col, 0.02, 0.6), spec, np.clip(r, 0.2, 1.0))


register_preset("cork/pinboard", "cork", {
    **rgb("color", (0.74, 0.55, 0.37), (-0.1, 0.08)), "granules": (20, 14, 30), "granule_var": (0.25, 0.1, 0.45),
    "gaps": (0.5, 0.3, 0.8), "relief": (0.06, 0.03, 0.1), "roughness": (0.78, 0.65, 0.92)})
register_preset("cork/floor_tile_sealed", "cork", {
    **rgb("color", (0.66, 0.46, 0.28), (-0.12, 0.08)), "seal": (0.8, 0.5, 1.0), "granules": (20, 12, 32),
    "granule_var": (0.3, 0.15, 0.5), "dark_frac": (0.15, 0.0, 0.35)})
register_preset("cork/wine_stopper", "cork", {
    **rgb("color", (0.78, 0.6, 0.42), (-0.1, 0.06)), "granules": (24, 18, 32), "pores": (0.5, 0.2, 0.9), "undulation": (0.03, 0.01, 0.05),
    "relief": (0.05, 0.02, 0.09), "gaps": (0.35, 0.1, 0.6)})
register_preset("cork/coarse_board", "cork", {
    **rgb("color", (0.7, 0.5, 0.32), (-0.12, 0.08)), "granules": (12, 8, 18), "relief": (0.09, 0.05, 0.14),
    "gaps": (0.8, 0.5, 1.0), "granule_var": (0.35, 0.15, 0.55), "dark_frac": (0.15, 0.0, 0.4)})
register_preset("cork/expanded_black", "cork", {
    **rgb("color", (0.2, 0.15, 0.12), (-0.06, 0.08)),
    "granules": (14, 8, 22), "relief": (0.1, 0.05, 0.15), "gaps": (0.8, 0.5, 1.0), "roughness": (0.82, 0.7, 0.95)},
    fixed={"dark_frac": 0.3, "pores": 0.2, **rgb_fixed("dark", (0.1, 0.08, 0.07))})
register_preset("cork/natural_slab", "cork", {
    **rgb("color", (0.62, 0.45, 0.3), (-0.12, 0.1)), "stretch": (2.2, 1.5, 3.0), "granules": (10, 8, 16),
    "pores": (0.7, 0.4, 1.0), "relief": (0.1, 0.06, 0.15), "undulation": (0.04, 0.02, 0.06),
    "color_var": (0.15, 0.05, 0.3)}, fixed={"gaps": 0.7})
register_preset("cork/mixed_dark_granules", "cork", {
    **rgb("color", (0.76, 0.58, 0.4), (-0.1, 0.06)), **rgb("dark", (0.28, 0.17, 0.1), (-0.1, 0.15)),
    "dark_frac": (0.4, 0.2, 0.6), "granules": (20, 14, 30), "granule_var": (0.2, 0.05, 0.4)})
register_preset("cork/fabric_sheet", "cork", {
    **rgb("color", (0.7, 0.52, 0.35), (-0.1, 0.08)), "seal": (0.5, 0.3, 0.8), "granules": (22, 14, 32),
    "stretch": (1.6, 1.0, 2.5), "pores": (0.5, 0.2, 0.8), "relief": (0.03, 0.01, 0.06)})
register_preset("cork/underlay_rubberised", "cork", {
    **rgb("color", (0.5, 0.4, 0.3), (-0.1, 0.08)),
    "dark_frac": (0.35, 0.2, 0.55), "granules": (20, 12, 30), "gaps": (0.6, 0.3, 0.9), "roughness": (0.8, 0.68, 0.92)},
    fixed=rgb_fixed("dark", (0.12, 0.12, 0.12)))
register_preset("cork/waxed_dark_floor", "cork", {
    **rgb("color", (0.45, 0.3, 0.18), (-0.1, 0.08)), "seal": (0.6, 0.4, 0.9), "granules": (18, 12, 28),
    "granule_var": (0.35, 0.2, 0.55), "color_var": (0.12, 0.04, 0.25)})
register_preset("cork/pale_coaster", "cork", {
    **rgb("color", (0.84, 0.7, 0.52), (-0.08, 0.05)), "granules": (22, 16, 30), "granule_var": (0.15, 0.05, 0.3), "undulation": (0.03, 0.01, 0.05),
    "gaps": (0.3, 0.1, 0.5), "relief": (0.04, 0.02, 0.07), "pores": (0.2, 0.0, 0.5)})
