"""Roofing: overlapping courses of clay tiles (flat, barrel, glazed), slates, asphalt shingles and wooden shakes.

Each course lies on the one below it (the ridge is up in the image): inside a course the tile thickens towards its
butt edge, which casts the step to the next course; vertical keyways separate the tiles of a course.

Physical ranges (``PHYSICAL``): all dielectrics, F0 about 0.04 (0.02-0.06 covers glazed tiles). Diffuse albedo of
"red/brown roof tiles" 0.1-0.35 and "corrugated roof" 0.1-0.15 linear in the measured albedo charts collected on
physicallybased.info; slate and asphalt shingles are darker (down to ~0.03). The real reference roof_slates_02
(docs/REALISM.md) has a median diffuse Y of 0.25, chroma C* 10, roughness 0.85 ± 0.04 and a mean normal tilt of 9
degrees.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, lerp, rgb, rgb_fixed, rgb_params, tint
from ..masonry_kit import courses, physical_finish, relief_band
from ..noise import F32, Tex, smoothstep
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.01, 0.75), "specular": (0.02, 0.06), "roughness": (0.15, 1.0)}
MOSS = np.array([0.07, 0.1, 0.025], F32)  # linear albedo of green moss/lichen

PARAMS = [
    *rgb_params("color", (0.6, 0.3, 0.18), "tile colour"),
    *rgb_params("color2", (0.45, 0.22, 0.14), "second tile colour (mixed / weathered tiles)"),
    P("tiles_x", 6, 2, 16, "tiles across the texture", "int"),
    P("rows", 8, 3, 24, "courses down the texture", "int"),
    P("stagger", 0.5, 0.0, 0.5, "offset of every other course in tiles"),
    P("thickness", 0.5, 0.0, 1.0, "step at each butt edge (tile thickness)"),
    P("profile", 0.0, 0.0, 1.0, "curved (barrel / S) tile profile across each tile"),
    P("scallop", 0.0, 0.0, 1.0, "rounded butt edges (fish-scale tiles)"),
    P("keyway", 0.01, 0.0, 0.03, "gap between the tiles of a course (texture widths)"),
    P("mix", 0.2, 0.0, 1.0, "fraction of tiles in the second colour"),
    P("tile_var", 0.12, 0.0, 0.4, "colour variation between tiles"),
    P("surface", 0.3, 0.0, 1.0, "relief of the tile face"),
    P("grain", 0.0, 0.0, 1.0, "grooves down the slope (split slate cleavage, wood shakes)"),
    P("ragged", 0.0, 0.0, 1.0, "irregular tile outlines (hand-split slate, shakes)"),
    P("moss", 0.0, 0.0, 1.0, "moss and lichen along the joints"),
    # calibrated (#23): reference roof_slates_02 (materials-cc0): mean roughness 0.85
    P("roughness", 0.75, 0.3, 1.0, "roughness of the tile face"),
    P("glaze", 0.0, 0.0, 1.0, "glazed tiles (smoother, slightly higher F0)"),
]


@register_class("roofing", PARAMS)
def roofing(p: dict, size: int, rng: np.random.Generator):
    """Roof coverings."""
    tex = Tex(size, rng)
    c1, c2 = color_param(p, "color"), color_param(p, "color2")
    nx = int(round(p["tiles_x"]))
    ny = int(round(p["rows"])) + (1 if p["stagger"] > 0 and int(round(p["rows"])) % 2 else 0)
    g = tex.sub()
    n_max = 16 * 24
    tv = g.standard_normal(n_max).astype(F32)
    pick = g.random(n_max).astype(F32)
    sx = g.standard_normal(n_max).astype(F32)
    e1, e2 = tex.fbm2(0.08, beta=2.4, detail=0.015)  # ragged outlines / colour mottle
    w1, w2 = tex.fbm2(0.25, beta=3.0)  # moss and weathering patches
    # cleavage / shake grain, runs down the slope; `detail` is measured in the stretched frame, so 0.1 cuts the
    # grooves across the slope near 40 cycles per texture
    streak = tex.fbm(0.3, beta=2.6, aniso=4.0, angle=np.pi / 2, detail=0.1)
    face = relief_band(tex, 16.0, 0.15 * p["surface"])
    fine = relief_band(tex, 56.0, 0.025 * (0.2 + p["surface"]))

    t = courses(tex, nx, ny, p["stagger"])
    row, fy, fx = t["row"], t["fy"], t["fx"]
    # butt edge of the course at fy_end: straight, scalloped (semicircular), ragged
    arc = 1 - np.sqrt(np.clip(1 - (2 * fx - 1) ** 2, 0, 1))
    fy_end = 1 - 0.45 * p["scallop"] * arc - 0.06 * p["ragged"] * np.clip(e1 + 0.5, 0, None)
    own = fy < fy_end
    # below a short (scalloped or ragged) butt the next course's tile shows, still thin at its top
    row_v = np.where(own, row, row + 1)
    xv = tex.u * nx + 0.5 + p["stagger"] * (row_v % 2 - 0.5)  # as in masonry_kit.courses
    col_v = np.floor(xv).astype(np.int32) % nx
    fxv = xv - np.floor(xv)
    tid = (row_v % ny) * nx + col_v
    wedge = np.where(own, fy / np.maximum(fy_end, 0.3), 0.0).astype(F32)
    # soften the butt step over ~1/4 of the exposure so the step's slope sits at the course scale
    butt = np.clip((fy_end - fy) * (1 / 0.12), 0, 1)
    butt = butt * butt * (3 - 2 * butt) * own
    wedge = wedge * butt + (1 - butt) * 0.0
    kw = p["keyway"] + 0.006 * p["ragged"] * np.clip(e2, 0, None)
    edge_x = np.minimum(fxv, 1 - fxv) / nx
    key = smoothstep(0.012, 0.0, edge_x - kw / 2) * (kw > 0)
    prof = (0.5 - 0.5 * np.cos(2 * np.pi * fxv)) if p["profile"] > 0 else np.zeros_like(fxv)
    h = (0.006 * p["thickness"] * wedge + 0.12 / nx * p["profile"] * prof - 0.0015 * key
         + 0.004 / ny * sx[tid] * fxv + face + fine + 0.0012 * p["grain"] * streak)

    sel = (pick[tid] < p["mix"]).astype(F32)
    c = lerp(np.broadcast_to(c1, fx.shape + (3,)), c2, sel)
    c = tint(c, tv[tid] + 0.4 * e2, p["tile_var"])
    shade = 1 - 0.45 * key - 0.25 * (1 - wedge) * (p["profile"] > 0) * (1 - prof)
    c = c * shade[..., None]
    joint = np.maximum(key, 1 - butt)
    mossm = smoothstep(0.3, 1.0, w1 + 0.8 * joint + 0.3 * e1) * p["moss"]
    c = lerp(c, MOSS * (1 + 0.3 * w2)[..., None], mossm)
    gz = p["glaze"] * (1 - mossm)
    r = p["roughness"] * (1 - 0.65 * gz) + 0.05 * e2 + 0.1 * key + 0.15 * mossm
    spec = 0.04 + 0.012 * gz - 0.008 * mossm
    return physical_finish(PHYSICAL, h + 0.001 * mossm * w2, c, spec[..., None], r)


register_preset("roofing/terracotta_plain", "roofing", {
    **rgb("color", (0.55, 0.34, 0.25), (-0.12, 0.1)), "tile_var": (0.12, 0.04, 0.3), "mix": (0.2, 0.0, 0.5),
    "rows": (8, 6, 12), "thickness": (0.6, 0.3, 0.9), "roughness": (0.7, 0.55, 0.85)}, fixed={"tiles_x": 6})
register_preset("roofing/clay_barrel", "roofing", {
    **rgb("color", (0.56, 0.36, 0.26), (-0.12, 0.1)), "profile": (0.8, 0.5, 1.0), "tiles_x": (6, 4, 8),
    "tile_var": (0.15, 0.05, 0.3), "rows": (6, 4, 8)}, fixed={"stagger": 0.0, "keyway": 0.0, "thickness": 0.7})
register_preset("roofing/glazed_green", "roofing", {
    **rgb("color", (0.18, 0.35, 0.22), (-0.08, 0.1)), "glaze": (0.8, 0.5, 1.0), "roughness": (0.45, 0.35, 0.6),
    "profile": (0.5, 0.2, 0.8)}, fixed={"tiles_x": 8, "rows": 8, "stagger": 0.0, "keyway": 0.0, "surface": 0.1,
                                       "mix": 0.0})
register_preset("roofing/slate_grey", "roofing", {
    **rgb("color", (0.3, 0.31, 0.33), (-0.08, 0.1)), "grain": (0.5, 0.2, 0.9), "ragged": (0.3, 0.0, 0.6),
    "rows": (10, 6, 14), "tile_var": (0.08, 0.0, 0.2), "roughness": (0.65, 0.5, 0.85)},
    fixed={**rgb_fixed("color2", (0.26, 0.27, 0.3)), "tiles_x": 6, "thickness": 0.4, "keyway": 0.006})
register_preset("roofing/welsh_slate_purple", "roofing", {
    **rgb("color", (0.32, 0.27, 0.33), (-0.08, 0.08)), "grain": (0.6, 0.3, 1.0), "mix": (0.3, 0.0, 0.6),
    "tiles_x": (5, 4, 8)},
    fixed={**rgb_fixed("color2", (0.28, 0.28, 0.32)), "rows": 10, "thickness": 0.35, "keyway": 0.005,
           "roughness": 0.6, "ragged": 0.15})
register_preset("roofing/asphalt_shingles", "roofing", {
    **rgb("color", (0.25, 0.24, 0.23), (-0.1, 0.12)), "tile_var": (0.15, 0.05, 0.3), "keyway": (0.008, 0.004, 0.014),
    "rows": (12, 8, 16), "surface": (0.7, 0.4, 1.0)},
    fixed={**rgb_fixed("color2", (0.18, 0.17, 0.16)), "tiles_x": 4, "thickness": 0.3, "mix": 0.4,
           "roughness": 0.85})
register_preset("roofing/cedar_shakes", "roofing", {
    **rgb("color", (0.5, 0.38, 0.27), (-0.15, 0.1)), "grain": (0.85, 0.5, 1.0), "ragged": (0.5, 0.2, 0.9),
    "tiles_x": (10, 7, 14), "tile_var": (0.2, 0.08, 0.35)},
    fixed={**rgb_fixed("color2", (0.4, 0.37, 0.34)), "rows": 8, "thickness": 0.8, "keyway": 0.006, "mix": 0.3,
           "roughness": 0.85, "surface": 0.2})
register_preset("roofing/fish_scale", "roofing", {
    **rgb("color", (0.35, 0.36, 0.4), (-0.1, 0.12)), "scallop": (0.9, 0.6, 1.0), "tiles_x": (8, 6, 12),
    "mix": (0.2, 0.0, 0.5)}, fixed={"rows": 12, "thickness": 0.5, "keyway": 0.004, "roughness": 0.6})
register_preset("roofing/mossy_clay", "roofing", {
    **rgb("color", (0.48, 0.33, 0.26), (-0.1, 0.1)), "moss": (0.6, 0.3, 1.0), "tile_var": (0.2, 0.05, 0.35),
    "profile": (0.5, 0.0, 0.9)}, fixed={"tiles_x": 6, "rows": 8, "roughness": 0.85, "surface": 0.5, "mix": 0.3})
register_preset("roofing/concrete_tiles", "roofing", {
    **rgb("color", (0.4, 0.38, 0.36), (-0.12, 0.12)), "profile": (0.35, 0.1, 0.6), "surface": (0.6, 0.3, 0.9),
    "moss": (0.15, 0.0, 0.4)},
    fixed={**rgb_fixed("color2", (0.32, 0.3, 0.29)), "tiles_x": 5, "rows": 7, "stagger": 0.0, "keyway": 0.003,
           "thickness": 0.8, "roughness": 0.82})
register_preset("roofing/spanish_s_tile", "roofing", {
    **rgb("color", (0.6, 0.4, 0.28), (-0.12, 0.08)), **rgb("color2", (0.5, 0.32, 0.24), (-0.1, 0.1)),
    "mix": (0.5, 0.2, 0.8), "tiles_x": (5, 3, 7)},
    fixed={"profile": 1.0, "stagger": 0.0, "keyway": 0.0, "rows": 5, "thickness": 0.9, "surface": 0.4,
           "tile_var": 0.18})
register_preset("roofing/weathered_slate_lichen", "roofing", {
    **rgb("color", (0.28, 0.29, 0.3), (-0.08, 0.1)), "moss": (0.35, 0.15, 0.7), "ragged": (0.6, 0.3, 1.0),
    "grain": (0.5, 0.2, 0.8)},
    fixed={**rgb_fixed("color2", (0.36, 0.35, 0.33)), "mix": 0.3, "tiles_x": 5, "rows": 9, "thickness": 0.4,
           "keyway": 0.005, "roughness": 0.8})
