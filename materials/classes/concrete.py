"""Concrete, plaster and asphalt: cast, board-formed, exposed-aggregate and polished concrete, smooth, troweled and
rough-cast plaster / stucco, asphalt road surfaces with paint markings.

Physical ranges (``PHYSICAL``): all dielectrics, F0 about 0.04 (0.02-0.06). Diffuse albedo in the measured charts
collected on physicallybased.info: new asphalt 0.04-0.05, aged asphalt 0.1-0.18, new concrete 0.4-0.55, aged
concrete 0.2-0.3, white cement 0.7-0.8 (linear), so 0.01-0.85 per channel with texture. Real references
(docs/REALISM.md): Asphalt026C (median diffuse Y 0.03, roughness 0.46), Road006 (Y 0.07, roughness 0.77),
Plaster001 (Y 0.65, chroma C* 2, roughness 0.79), plastered_stone_wall (Y 0.05, roughness 0.89, tilt 8 degrees).
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, lerp, rgb, rgb_fixed, rgb_params, tint
from ..masonry_kit import physical_finish, relief_band, stones
from ..noise import F32, Tex, band_field, smoothstep
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.01, 0.85), "specular": (0.02, 0.06), "roughness": (0.12, 1.0)}
PAINT = np.array([0.7, 0.68, 0.62], F32)  # linear albedo of white road paint

PARAMS = [
    *rgb_params("color", (0.6, 0.59, 0.56), "cement / plaster / binder colour"),
    *rgb_params("color2", (0.45, 0.42, 0.38), "aggregate stone colour"),
    P("color_var", 0.15, 0.0, 0.5, "blotchy colour variation"),
    P("aggregate", 0.0, 0.0, 1.0, "exposed aggregate stones (fraction of cells showing a stone)"),
    P("agg_count", 30, 12, 64, "aggregate stones across the texture", "int"),
    P("undulation", 0.3, 0.0, 1.0, "broad unevenness of the surface"),
    P("stucco", 0.0, 0.0, 1.0, "knock-down stucco dabs (flattened blobs)"),
    P("grit", 0.3, 0.0, 1.0, "sand grit / rough-cast relief"),
    P("pits", 0.2, 0.0, 1.0, "air holes (bug holes)"),
    P("cracks", 0.0, 0.0, 1.0, "hairline and wider cracks"),
    P("boards", 0, 0, 16, "formwork boards imprinted across the height (0: none)", "int"),
    P("panels", 0, 0, 8, "control-joint / panel grid across the texture (0: none)", "int"),
    P("trowel", 0.0, 0.0, 1.0, "trowel marks: burnished, glossier sweeps"),
    P("stains", 0.0, 0.0, 1.0, "vertical water streaks and stains"),
    P("marking", 0.0, 0.0, 1.0, "worn painted road marking across the texture"),
    # calibrated (#23): reference (materials-cc0): asphalt 0.46 and 0.77, plaster 0.79 and 0.89 mean roughness
    P("roughness", 0.72, 0.3, 1.0, "roughness"),
    P("polish", 0.0, 0.0, 1.0, "ground and polished / sealed finish (smoother, flatter)"),
]


@register_class("concrete", PARAMS)
def concrete(p: dict, size: int, rng: np.random.Generator):
    """Concrete, plaster and asphalt."""
    tex = Tex(size, rng)
    c1, c2 = color_param(p, "color"), color_param(p, "color2")
    m1, m2 = tex.fbm2(0.2, beta=3.0)  # colour blotches, trowel sweeps
    k1, k2 = tex.fbm2(0.35, beta=3.3)  # crack lines at the zero crossings; stain / wear patches
    streak = tex.fbm(0.5, beta=2.0, aniso=10.0, angle=np.pi / 2)  # runs down the wall
    st = stones(tex, p["agg_count"], 1.0, 0.12, enabled=p["aggregate"] > 0)
    und = relief_band(tex, 6.0, 0.08 * p["undulation"])
    dabs = relief_band(tex, 12.0, 1.0)  # unit slope: thresholded below, scaled by `stucco`
    grit = relief_band(tex, 24.0, 0.08 * p["grit"])  # ~11 px periods at 256²: sand and grit clumps
    pitf = band_field(size, tex.seed(), 36.0)
    grain = tex.fbm(0.4, beta=2.6, aniso=4.0, angle=0.0, detail=0.1)  # board grain along u, cut near 40 cycles across
    g = tex.sub()
    boff = g.standard_normal(16).astype(F32)

    flat = 1 - 0.85 * p["polish"]
    # stucco: blobs with flattened tops (knock-down), relief at the blob scale
    dab = dabs / max(float(np.abs(dabs).max()), 1e-9)
    dab_h = smoothstep(0.0, 0.35, dab) * 0.004 * p["stucco"]
    pit = smoothstep(1.5, 2.3, -pitf / max(float(pitf.std()), 1e-9)) * p["pits"]
    crack = np.exp(-(k1 * (6.0 - 2.0 * p["cracks"])) ** 2) * smoothstep(0.0, 0.6, k2 + p["cracks"] - 0.5) * p["cracks"]
    nb = int(round(p["boards"]))
    if nb:
        y = tex.v * nb + 0.5
        bi = np.floor(y).astype(np.int32) % nb
        fy = y - np.floor(y)
        seam = smoothstep(0.2, 0.0, np.minimum(fy, 1 - fy))
        board_h = 0.0008 * grain + 0.0015 * boff[bi] / nb + 0.001 * seam
    else:
        board_h = np.zeros_like(grain)
        seam = board_h
    npn = int(round(p["panels"]))
    if npn:
        fu = tex.u * npn + 0.5
        fv = tex.v * npn + 0.5
        e = np.minimum(np.minimum(fu % 1, 1 - fu % 1), np.minimum(fv % 1, 1 - fv % 1)) / npn
        groove = smoothstep(0.012, 0.003, e)
    else:
        groove = np.zeros_like(grain)
    agg = st["mask"] * (st["rnd"][st["id"]] < p["aggregate"])
    h = (und + flat * (grit + board_h) + dab_h + 0.0015 / max(st["n"], 1) * 8 * st["dome"] * agg * flat
         - 0.0008 * pit - 0.0008 * crack - 0.003 * groove)

    col = tint(c1, m1 + 0.4 * k2, p["color_var"])
    col = lerp(col, tint(c2, (st["rnd"][st["id"]] - 0.5) * 2, 0.35), agg)
    stain = smoothstep(0.2, 1.2, streak + 0.5 * k2) * p["stains"]
    col = col * (1 - 0.45 * stain - 0.5 * pit - 0.5 * crack - 0.3 * groove - 0.1 * seam)[..., None]
    if p["marking"] > 0:
        line = smoothstep(0.08, 0.06, np.abs(tex.u - 0.5))  # a 0.12-wide stripe down the texture
        wear = smoothstep(-0.3, 0.5, m2 + 1.4 * p["marking"] - 1.0) * (1 - agg * 0.7)
        paint = line * wear
    else:
        paint = np.zeros_like(grain)
    col = lerp(col, PAINT * (1 - 0.1 * m2)[..., None], paint)
    tr = smoothstep(0.2, 1.0, m2) * p["trowel"]
    r = (p["roughness"] * (1 - 0.7 * p["polish"]) * (1 - 0.45 * tr) + 0.06 * k2 + 0.15 * pit + 0.1 * crack
         - 0.1 * paint)
    spec = 0.04 + 0.008 * p["polish"] + 0.006 * tr - 0.01 * pit
    return physical_finish(PHYSICAL, h + 0.0003 * paint, col, spec[..., None], r)


register_preset("concrete/cast_smooth", "concrete", {
    **rgb("color", (0.6, 0.59, 0.56), (-0.12, 0.1)), "pits": (0.4, 0.1, 0.8), "color_var": (0.15, 0.05, 0.3),
    "undulation": (0.3, 0.1, 0.6), "roughness": (0.7, 0.55, 0.85)}, fixed={"grit": 0.25})
register_preset("concrete/board_formed", "concrete", {
    **rgb("color", (0.55, 0.54, 0.52), (-0.12, 0.1)), "boards": (8, 5, 12), "pits": (0.3, 0.0, 0.6),
    "stains": (0.2, 0.0, 0.5)}, fixed={"grit": 0.2, "roughness": 0.75})
register_preset("concrete/exposed_aggregate", "concrete", {
    **rgb("color", (0.55, 0.53, 0.5), (-0.1, 0.1)), **rgb("color2", (0.5, 0.44, 0.38), (-0.15, 0.15)),
    "aggregate": (0.75, 0.5, 1.0), "agg_count": (24, 14, 36)}, fixed={"grit": 0.4, "roughness": 0.78, "pits": 0.1})
register_preset("concrete/polished_floor", "concrete", {
    **rgb("color", (0.5, 0.49, 0.47), (-0.12, 0.12)), "polish": (0.8, 0.5, 1.0), "aggregate": (0.3, 0.0, 0.6),
    "color_var": (0.2, 0.05, 0.4), "panels": (2, 1, 4)},
    fixed={**rgb_fixed("color2", (0.35, 0.33, 0.3)), "agg_count": 40, "roughness": 0.6, "cracks": 0.1})
register_preset("concrete/weathered_stained", "concrete", {
    **rgb("color", (0.45, 0.44, 0.41), (-0.12, 0.1)), "stains": (0.7, 0.4, 1.0), "cracks": (0.3, 0.0, 0.7),
    "color_var": (0.3, 0.15, 0.5), "pits": (0.4, 0.1, 0.8)}, fixed={"roughness": 0.8, "grit": 0.5, "undulation": 0.5})
register_preset("concrete/cracked_slab", "concrete", {
    **rgb("color", (0.5, 0.49, 0.46), (-0.12, 0.1)), "cracks": (0.8, 0.5, 1.0), "panels": (2, 1, 3),
    "undulation": (0.6, 0.3, 1.0)}, fixed={"grit": 0.45, "roughness": 0.78, "color_var": 0.25})
register_preset("concrete/plaster_smooth", "concrete", {
    **rgb("color", (0.82, 0.81, 0.78), (-0.1, 0.06)), "undulation": (0.4, 0.1, 0.8), "cracks": (0.1, 0.0, 0.4),
    "color_var": (0.05, 0.0, 0.1)}, fixed={"grit": 0.1, "pits": 0.05, "roughness": 0.8})
register_preset("concrete/venetian_plaster", "concrete", {
    **rgb("color", (0.72, 0.62, 0.5), (-0.15, 0.06)), "trowel": (0.8, 0.5, 1.0), "color_var": (0.2, 0.1, 0.3),
    "roughness": (0.45, 0.3, 0.65)}, fixed={"grit": 0.05, "pits": 0.0, "undulation": 0.3, "polish": 0.4})
register_preset("concrete/stucco_knockdown", "concrete", {
    **rgb("color", (0.78, 0.74, 0.66), (-0.12, 0.08)), "stucco": (0.8, 0.5, 1.0), "grit": (0.4, 0.2, 0.7),
    "stains": (0.1, 0.0, 0.4)}, fixed={"roughness": 0.85, "pits": 0.0, "color_var": 0.08})
register_preset("concrete/rough_cast_dash", "concrete", {
    **rgb("color", (0.7, 0.68, 0.64), (-0.12, 0.1)), **rgb("color2", (0.55, 0.5, 0.45), (-0.15, 0.1)),
    "grit": (0.9, 0.6, 1.0), "aggregate": (0.5, 0.3, 0.8)},
    fixed={"agg_count": 56, "roughness": 0.85, "pits": 0.0, "undulation": 0.5})
register_preset("concrete/asphalt_road", "concrete", {
    **rgb("color", (0.19, 0.19, 0.19), (-0.05, 0.1)), **rgb("color2", (0.38, 0.37, 0.35), (-0.12, 0.12)),
    "aggregate": (0.55, 0.3, 0.8), "agg_count": (40, 30, 52), "roughness": (0.65, 0.45, 0.85)},
    fixed={"grit": 0.6, "pits": 0.3, "color_var": 0.1, "undulation": 0.2})
register_preset("concrete/asphalt_cracked_marked", "concrete", {
    **rgb("color", (0.2, 0.2, 0.2), (-0.08, 0.1)), "cracks": (0.6, 0.3, 1.0), "marking": (0.6, 0.3, 1.0),
    "stains": (0.3, 0.0, 0.6)},
    fixed={**rgb_fixed("color2", (0.36, 0.35, 0.33)), "aggregate": 0.45, "agg_count": 44, "grit": 0.5,
           "roughness": 0.72, "color_var": 0.15})
