"""Bricks: fired-clay, glazed, painted and concrete bricks and blocks laid in courses with mortar joints.

Physical ranges (``PHYSICAL``): brick and mortar are dielectrics, F0 about 0.04 (0.02-0.06 covers glazes and
dusty mortar). Diffuse albedo: "red/brown roof tiles" 0.1-0.35 and "aged concrete" 0.2-0.3 linear in the
measured albedo charts collected on physicallybased.info (and the DONTNOD albedo chart it cites); painted
white brick reaches ~0.8. The real reference scan Bricks075B (docs/REALISM.md) has a median diffuse Y of 0.05,
chroma C* 8, roughness 0.52 ± 0.07 and a mean normal tilt of 16 degrees, which the presets aim at.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, lerp, rgb, rgb_fixed, rgb_params, tint
from ..masonry_kit import bevel_profile, courses, physical_finish, relief_band
from ..noise import F32, Tex, smoothstep
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.01, 0.85), "specular": (0.02, 0.06), "roughness": (0.2, 1.0)}

PARAMS = [
    *rgb_params("color", (0.55, 0.25, 0.16), "brick colour"),
    *rgb_params("color2", (0.3, 0.14, 0.1), "second brick colour (over-fired / mixed bricks)"),
    *rgb_params("mortar", (0.62, 0.6, 0.56), "mortar colour"),
    P("bricks_x", 4, 1, 10, "bricks across the texture", "int"),
    P("rows", 12, 2, 28, "courses down the texture", "int"),
    P("stagger", 0.5, 0.0, 0.5, "offset of every other course in bricks (0.5: running bond, 0: stack bond)"),
    P("joint", 0.012, 0.003, 0.03, "mortar joint width (texture widths)"),
    P("bevel", 0.012, 0.006, 0.03, "rounded brick shoulder (texture widths)"),
    P("recess", 0.5, 0.0, 1.0, "depth of the mortar below the brick face"),
    P("mix", 0.2, 0.0, 1.0, "fraction of bricks in the second colour"),
    P("brick_var", 0.15, 0.0, 0.5, "colour variation between bricks"),
    P("mottle", 0.3, 0.0, 1.0, "colour mottling within a brick"),
    P("surface", 0.4, 0.0, 1.0, "relief of the brick face (sand-faced, handmade)"),
    P("chips", 0.3, 0.0, 1.0, "chipped and worn brick edges"),
    P("tilt", 0.3, 0.0, 1.0, "uneven laying (tilt of each brick)"),
    P("soot", 0.0, 0.0, 1.0, "dark grime patches"),
    P("efflorescence", 0.0, 0.0, 1.0, "white salt bloom near the joints"),
    # calibrated (#23): reference Bricks075B (materials-cc0): mean roughness 0.52 (p10-p90 0.43-0.60)
    P("roughness", 0.7, 0.35, 1.0, "roughness of the brick face"),
    P("glaze", 0.0, 0.0, 1.0, "glazed face (smoother, slightly higher F0)"),
]


@register_class("bricks", PARAMS)
def bricks(p: dict, size: int, rng: np.random.Generator):
    """Brick walls and paving."""
    tex = Tex(size, rng)
    c1, c2, cm = color_param(p, "color"), color_param(p, "color2"), color_param(p, "mortar")
    t = courses(tex, p["bricks_x"], p["rows"], p["stagger"])
    g = tex.sub()
    n_max = 10 * 28  # fixed draw counts: the layout of a seed does not depend on the parameters
    bv = g.standard_normal(n_max).astype(F32)
    pick = g.random(n_max).astype(F32)
    tx, ty = g.standard_normal((2, n_max)).astype(F32)
    m1, m2 = tex.fbm2(0.12, beta=2.6, detail=0.02)  # mottling / chip outline
    w1, w2 = tex.fbm2(0.3, beta=3.2)  # grime and salt patches
    face = relief_band(tex, 20.0, 0.22 * p["surface"])  # pitted brick face at ~13 px periods at 256²
    grain = relief_band(tex, 48.0, 0.035 * (0.3 + p["surface"]))  # sand grain, a minority of the slope
    bid = t["id"]
    nx, ny = t["nx"], t["ny"]
    # chips: the brick outline eaten away where the mottle noise is high, only near edges
    chip = p["chips"] * 0.012 * np.clip(m2 - 0.3, 0, None)
    prof = bevel_profile(t["edge"] - chip, p["joint"], p["bevel"])
    mort = 1 - prof
    tilt = p["tilt"] * 0.04 * (tx[bid] * (t["fx"] - 0.5) / nx + ty[bid] * (t["fy"] - 0.5) / ny)
    h = (0.002 + 0.005 * p["recess"]) * prof + tilt * prof + face * prof + grain * (1 - 0.5 * p["glaze"] * prof)

    sel = (pick[bid] < p["mix"]).astype(F32)
    col = lerp(np.broadcast_to(c1, prof.shape + (3,)), c2, sel)
    col = tint(col, bv[bid] + 0.6 * p["mottle"] * m1, p["brick_var"] + 0.1 * p["mottle"])
    col = lerp(cm * (1 + 0.1 * m2)[..., None], col, prof)
    soot = smoothstep(0.2, 1.2, w1 + 0.3 * m1) * p["soot"]
    col = col * (1 - 0.6 * soot)[..., None]
    salt = smoothstep(0.3, 1.3, w2 + 0.8 * mort - 0.5 * t["fy"]) * p["efflorescence"]
    col = lerp(col, np.full(3, 0.7, F32), 0.8 * salt)
    gz = p["glaze"] * prof
    r = p["roughness"] * (1 - 0.7 * gz) + 0.06 * m1 + 0.1 * mort + 0.1 * soot
    spec = 0.04 + 0.012 * gz - 0.006 * mort
    return physical_finish(PHYSICAL, h, col, spec[..., None], r)


register_preset("bricks/red_common", "bricks", {
    **rgb("color", (0.5, 0.3, 0.22), (-0.12, 0.1)), "brick_var": (0.15, 0.05, 0.3), "rows": (12, 8, 16),
    "mix": (0.15, 0.0, 0.4), "chips": (0.3, 0.0, 0.7), "surface": (0.5, 0.2, 0.8), "recess": (0.5, 0.2, 0.8),
    "roughness": (0.6, 0.4, 0.8)}, fixed={"bricks_x": 4})
register_preset("bricks/london_stock", "bricks", {
    **rgb("color", (0.55, 0.47, 0.35), (-0.12, 0.1)), **rgb("color2", (0.33, 0.26, 0.2), (-0.1, 0.1)),
    "mix": (0.35, 0.1, 0.6), "mottle": (0.6, 0.3, 0.9), "soot": (0.3, 0.0, 0.7), "surface": (0.6, 0.3, 0.9)},
    fixed={"rows": 12, "bricks_x": 4, "chips": 0.5})
register_preset("bricks/weathered_old", "bricks", {
    **rgb("color", (0.5, 0.27, 0.2), (-0.12, 0.1)), "chips": (0.8, 0.5, 1.0), "recess": (0.8, 0.5, 1.0),
    "efflorescence": (0.3, 0.0, 0.7), "soot": (0.3, 0.0, 0.7), "tilt": (0.6, 0.3, 1.0), "joint": (0.016, 0.01, 0.024)},
    fixed={"rows": 10, "bricks_x": 3, "surface": 0.7, "brick_var": 0.25})
register_preset("bricks/painted_white", "bricks", {
    **rgb("color", (0.8, 0.79, 0.75), (-0.1, 0.06)), "roughness": (0.6, 0.4, 0.8), "chips": (0.3, 0.0, 0.7),
    "soot": (0.15, 0.0, 0.4), "rows": (12, 8, 16)},
    fixed={**rgb_fixed("mortar", (0.76, 0.75, 0.72)), **rgb_fixed("color2", (0.76, 0.76, 0.73)), "brick_var": 0.03,
           "mottle": 0.1, "surface": 0.3, "mix": 0.0, "recess": 0.3})
register_preset("bricks/glazed_blue", "bricks", {
    **rgb("color", (0.2, 0.32, 0.5), (-0.1, 0.12)), "glaze": (0.8, 0.5, 1.0), "brick_var": (0.1, 0.0, 0.25),
    "roughness": (0.5, 0.4, 0.7)},
    fixed={"rows": 14, "bricks_x": 4, "surface": 0.15, "chips": 0.1, "mottle": 0.15, "mix": 0.0})
register_preset("bricks/engineering_blue", "bricks", {
    **rgb("color", (0.2, 0.18, 0.2), (-0.08, 0.1)), "roughness": (0.55, 0.4, 0.75), "brick_var": (0.12, 0.0, 0.3),
    "stagger": (0.5, 0.0, 0.5)},
    fixed={**rgb_fixed("mortar", (0.45, 0.44, 0.42)), "rows": 12, "bricks_x": 4, "surface": 0.2, "chips": 0.15,
           "mix": 0.0})
register_preset("bricks/handmade_rustic", "bricks", {
    **rgb("color", (0.56, 0.34, 0.24), (-0.12, 0.1)), **rgb("color2", (0.4, 0.29, 0.24), (-0.1, 0.1)),
    "surface": (0.85, 0.5, 1.0), "tilt": (0.7, 0.3, 1.0), "mottle": (0.7, 0.4, 1.0), "mix": (0.4, 0.1, 0.7),
    "bevel": (0.02, 0.012, 0.03)}, fixed={"rows": 10, "bricks_x": 3, "chips": 0.6, "joint": 0.018})
register_preset("bricks/sooty_reclaimed", "bricks", {
    **rgb("color", (0.45, 0.24, 0.17), (-0.1, 0.1)), "soot": (0.7, 0.4, 1.0), "chips": (0.7, 0.3, 1.0),
    "brick_var": (0.3, 0.15, 0.5), "mix": (0.3, 0.0, 0.6)},
    fixed={**rgb_fixed("mortar", (0.4, 0.38, 0.35)), "rows": 12, "bricks_x": 4, "surface": 0.6})
register_preset("bricks/stack_bond_pavers", "bricks", {
    **rgb("color", (0.45, 0.3, 0.24), (-0.12, 0.12)), "bricks_x": (6, 4, 8), "brick_var": (0.2, 0.05, 0.4),
    "joint": (0.006, 0.003, 0.01), "tilt": (0.5, 0.2, 0.9)},
    fixed={"rows": 12, "stagger": 0.0, "recess": 0.2, "surface": 0.3, "roughness": 0.72, "chips": 0.4})
register_preset("bricks/roman_thin", "bricks", {
    **rgb("color", (0.55, 0.42, 0.33), (-0.12, 0.1)), "rows": (22, 16, 28), "brick_var": (0.2, 0.05, 0.4),
    "mix": (0.25, 0.0, 0.5)}, fixed={"bricks_x": 2, "joint": 0.008, "bevel": 0.008, "recess": 0.6, "surface": 0.3})
register_preset("bricks/concrete_blocks", "bricks", {
    **rgb("color", (0.5, 0.49, 0.47), (-0.12, 0.1)), "surface": (0.8, 0.5, 1.0), "brick_var": (0.06, 0.0, 0.15),
    "rows": (4, 3, 6)},
    fixed={**rgb_fixed("mortar", (0.55, 0.54, 0.52)), "bricks_x": 2, "joint": 0.01, "bevel": 0.008, "recess": 0.3,
           "mottle": 0.4, "roughness": 0.8, "mix": 0.0, "chips": 0.2})
register_preset("bricks/yellow_fire_brick", "bricks", {
    **rgb("color", (0.72, 0.64, 0.5), (-0.1, 0.08)), "mottle": (0.5, 0.2, 0.8), "soot": (0.4, 0.0, 0.8),
    "roughness": (0.65, 0.5, 0.8)},
    fixed={**rgb_fixed("color2", (0.55, 0.42, 0.3)), "mix": 0.15, "rows": 12, "bricks_x": 4, "joint": 0.005,
           "recess": 0.15, "surface": 0.3})
