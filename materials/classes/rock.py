"""Rock: rock faces (granite, sandstone strata, limestone, slate outcrops), lava (vesicular, ropy), and loose or set
stones (gravel, pebbles, cobbles, setts) on a cell pattern.

Physical ranges (``PHYSICAL``): rock-forming minerals are dielectrics with F0 about 0.04-0.05 (quartz 0.045,
calcite 0.06 at the top); wet rock stays dielectric (water 0.02), so 0.02-0.07. Diffuse albedo: "rock" 0.3-0.4
and "gravel" 0.13 linear in the measured charts collected on physicallybased.info, basalt and fresh lava much
darker. The real references (docs/REALISM.md) go lower: Rock029 (median diffuse Y 0.10, chroma C* 25, roughness
0.76, mean tilt 23 degrees), Rock035 (Y 0.01, tilt 24 degrees), Lava002 (Y 0.04, roughness 0.41, tilt 22
degrees), so 0.005-0.7 per channel. Rock relief is steep: the presets aim at 10-25 degrees of mean tilt.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, lerp, rgb, rgb_fixed, rgb_params, tint
from ..masonry_kit import physical_finish, relief_band, stones
from ..noise import F32, Tex, band_field, smoothstep
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.005, 0.7), "specular": (0.02, 0.07), "roughness": (0.12, 1.0)}
LICHEN = np.array([0.3, 0.3, 0.16], F32)  # linear albedo of pale crustose lichen

PARAMS = [
    *rgb_params("color", (0.4, 0.37, 0.33), "rock colour"),
    *rgb_params("color2", (0.25, 0.22, 0.2), "second mineral / weathered colour"),
    *rgb_params("joint", (0.12, 0.1, 0.08), "fill between stones (soil, sand, mortar)"),
    P("color_var", 0.25, 0.0, 0.6, "colour variation"),
    P("speckle", 0.0, 0.0, 1.0, "mineral grain speckle in the second colour"),
    P("stones", 0, 0, 40, "loose or set stones across the texture (0: one rock face)", "int"),
    P("jitter", 1.0, 0.2, 1.0, "irregularity of the stone layout (low: setts in rows)"),
    P("stone_gap", 0.1, 0.0, 0.4, "joints between stones (cell widths)"),
    P("dome", 0.6, 0.0, 1.0, "rounding of each stone"),
    P("crags", 0.5, 0.0, 1.0, "craggy ridged relief of a rock face"),
    P("crag_scale", 0.25, 0.08, 0.6, "size of the crags (texture widths)"),
    P("strata", 0.0, 0.0, 1.0, "sedimentary layers as ledges"),
    P("strata_count", 8, 3, 20, "layers down the texture", "int"),
    P("cracks", 0.0, 0.0, 1.0, "cracks and joints in the rock"),
    P("vesicles", 0.0, 0.0, 1.0, "gas bubble holes (lava, pumice)"),
    P("flow", 0.0, 0.0, 1.0, "ropy flow folds (pahoehoe lava)"),
    P("lichen", 0.0, 0.0, 1.0, "lichen patches"),
    P("wet", 0.0, 0.0, 1.0, "wetness (darker, glossier)"),
    # calibrated (#23): reference rock scans (materials-cc0): Rock029 0.76, Rock035 0.69, Lava002 0.41 mean roughness
    P("roughness", 0.68, 0.3, 1.0, "roughness of the dry rock"),
]


@register_class("rock", PARAMS)
def rock(p: dict, size: int, rng: np.random.Generator):
    """Rock faces, lava and stones."""
    tex = Tex(size, rng)
    c1, c2, cj = color_param(p, "color"), color_param(p, "color2"), color_param(p, "joint")
    ns = int(round(p["stones"]))
    st = stones(tex, max(ns, 1), p["jitter"], p["stone_gap"], enabled=ns > 0)
    cr1, cr2 = tex.fbm2(p["crag_scale"], beta=3.0, detail=0.025)  # crags (ridged) and crack lines
    m1, m2 = tex.fbm2(0.15, beta=2.6)  # colour variation, lichen / wet patches
    sp = band_field(size, tex.seed(), 48.0)  # mineral grains: colour only
    vs = band_field(size, tex.seed(), 20.0)  # vesicle holes
    warpf = tex.fbm(0.3, beta=3.2, detail=0.05)  # smooth: its gradient bends the strata and folds
    surf = relief_band(tex, 14.0, 0.12 * (0.3 + p["crags"]))  # mid-scale roughness of every rock surface
    fine = relief_band(tex, 52.0, 0.03)  # fine grain, kept a minority of the slope

    ridged = (1 - np.sqrt(cr1 * cr1 + 0.04)) ** 2  # crests where the field crosses zero, rounded (no kink)
    face = 0.03 * p["crag_scale"] * p["crags"] * ridged
    nl = int(round(p["strata_count"]))
    ph = tex.v * nl + 0.6 * p["strata"] * warpf + 0.5
    fr = ph - np.floor(ph)
    ledge = smoothstep(0.0, 0.15, fr) * (1 - fr)  # a step up, then a slope back down: ledges
    face = face + 0.012 / nl * p["strata"] * ledge
    crack = np.exp(-(cr2 * 6.0) ** 2) * smoothstep(-0.2, 0.6, m2 + p["cracks"] - 0.5) * p["cracks"]
    ves = smoothstep(1.0, 2.0, vs) * p["vesicles"]
    rope = np.sin(2 * np.pi * (tex.v * 10 + 0.35 * warpf + 0.08 * cr1)) * p["flow"]  # small phase warp: folds stay ~25 px apart
    if ns > 0:
        sh = 0.07 / ns * (0.3 + p["dome"]) * st["dome"]
        body = st["mask"]
        h = sh + body * (0.4 * face + surf) + (1 - body) * 0.3 * fine
    else:
        body = np.ones_like(cr1)
        h = face + surf
    h = h + fine - 0.002 * crack - 0.0015 * ves + 0.0015 * rope * body

    per = (st["rnd"][st["id"]] - 0.5) * 2 if ns > 0 else np.zeros_like(cr1)
    mix = np.clip(0.5 + 0.5 * m1 + 0.6 * per * (ns > 0), 0, 1)
    col = lerp(np.broadcast_to(c1, cr1.shape + (3,)), c2, mix * mix)
    col = tint(col, m2 + 0.8 * per + 2.0 * face * (ns == 0), p["color_var"])
    col = lerp(col, c2 * 0.6, smoothstep(0.8, 1.6, sp) * p["speckle"])
    col = lerp(cj * (1 + 0.2 * m2)[..., None], col, body)
    col = col * (1 - 0.5 * crack - 0.5 * ves)[..., None]
    lich = smoothstep(0.4, 1.0, m2 + 0.7 * p["lichen"] - 0.5 + 0.3 * st["dome"]) * p["lichen"] * body
    col = lerp(col, LICHEN * (1 + 0.3 * m1)[..., None], lich)
    wet = smoothstep(-0.6, 0.4, m1 + 2 * p["wet"] - 1.2) * p["wet"]
    col = col * (1 - 0.45 * wet)[..., None]
    r = p["roughness"] * (1 - 0.55 * wet) + 0.06 * m1 + 0.1 * crack + 0.15 * lich + 0.1 * (1 - body)
    spec = 0.04 + 0.01 * p["speckle"] * smoothstep(0.8, 1.6, sp) - 0.008 * lich + 0.005 * wet
    return physical_finish(PHYSICAL, h, col, spec[..., None], r)


register_preset("rock/granite_cliff", "rock", {
    **rgb("color", (0.5, 0.47, 0.45), (-0.15, 0.12)), **rgb("color2", (0.32, 0.28, 0.28), (-0.1, 0.1)),
    "speckle": (0.6, 0.3, 1.0), "crags": (0.7, 0.4, 1.0), "cracks": (0.3, 0.0, 0.7), "crag_scale": (0.3, 0.15, 0.5)},
    fixed={"roughness": 0.7})
register_preset("rock/sandstone_strata", "rock", {
    **rgb("color", (0.66, 0.5, 0.36), (-0.15, 0.1)), **rgb("color2", (0.55, 0.36, 0.24), (-0.1, 0.1)),
    "strata": (0.8, 0.5, 1.0), "strata_count": (8, 4, 14), "crags": (0.3, 0.1, 0.6)},
    fixed={"roughness": 0.76, "color_var": 0.2})
register_preset("rock/limestone_face", "rock", {
    **rgb("color", (0.68, 0.66, 0.6), (-0.15, 0.1)), "crags": (0.6, 0.3, 0.9), "cracks": (0.4, 0.1, 0.8),
    "lichen": (0.2, 0.0, 0.5), "crag_scale": (0.35, 0.2, 0.6)},
    fixed={**rgb_fixed("color2", (0.5, 0.49, 0.46)), "roughness": 0.72, "strata": 0.3})
register_preset("rock/slate_outcrop", "rock", {
    **rgb("color", (0.25, 0.26, 0.28), (-0.08, 0.1)), "strata": (0.6, 0.3, 1.0), "strata_count": (14, 8, 20),
    "cracks": (0.6, 0.3, 1.0)},
    fixed={**rgb_fixed("color2", (0.2, 0.2, 0.22)), "crags": 0.4, "roughness": 0.65, "color_var": 0.15})
register_preset("rock/lava_vesicular", "rock", {
    **rgb("color", (0.16, 0.14, 0.13), (-0.06, 0.1)), "vesicles": (0.8, 0.5, 1.0), "crags": (0.6, 0.3, 1.0),
    "roughness": (0.6, 0.4, 0.8)},
    fixed={**rgb_fixed("color2", (0.25, 0.13, 0.09)), "color_var": 0.3, "crag_scale": 0.15})
register_preset("rock/lava_pahoehoe", "rock", {
    **rgb("color", (0.12, 0.11, 0.11), (-0.05, 0.08)), "flow": (0.8, 0.5, 1.0), "roughness": (0.42, 0.3, 0.6),
    "vesicles": (0.25, 0.0, 0.6)},
    fixed={**rgb_fixed("color2", (0.18, 0.12, 0.1)), "crags": 0.2, "color_var": 0.2})
register_preset("rock/gravel_fine", "rock", {
    **rgb("color", (0.5, 0.47, 0.43), (-0.15, 0.12)), **rgb("color2", (0.35, 0.3, 0.27), (-0.1, 0.1)),
    "stones": (18, 14, 24), "color_var": (0.35, 0.2, 0.5), "stone_gap": (0.08, 0.02, 0.15)},
    fixed={"dome": 0.8, "crags": 0.2, "roughness": 0.74})
register_preset("rock/gravel_coarse", "rock", {
    **rgb("color", (0.45, 0.43, 0.4), (-0.15, 0.12)), **rgb("color2", (0.3, 0.27, 0.25), (-0.1, 0.1)),
    "stones": (14, 10, 20), "crags": (0.5, 0.2, 0.8), "color_var": (0.35, 0.2, 0.5)},
    fixed={"dome": 0.6, "stone_gap": 0.06, "roughness": 0.74, "crag_scale": 0.1})
register_preset("rock/river_pebbles_wet", "rock", {
    **rgb("color", (0.42, 0.38, 0.34), (-0.12, 0.12)), **rgb("color2", (0.22, 0.22, 0.24), (-0.1, 0.1)),
    "stones": (12, 8, 18), "wet": (0.6, 0.3, 1.0), "dome": (0.9, 0.6, 1.0)},
    fixed={"stone_gap": 0.12, "crags": 0.0, "roughness": 0.6, "color_var": 0.3})
register_preset("rock/beach_pebbles", "rock", {
    **rgb("color", (0.6, 0.56, 0.5), (-0.15, 0.1)), **rgb("color2", (0.35, 0.33, 0.32), (-0.1, 0.12)),
    "stones": (18, 12, 26), "color_var": (0.4, 0.2, 0.6), "speckle": (0.3, 0.0, 0.6)},
    fixed={**rgb_fixed("joint", (0.45, 0.4, 0.32)), "dome": 1.0, "stone_gap": 0.15, "crags": 0.0,
           "roughness": 0.7})
register_preset("rock/granite_setts", "rock", {
    **rgb("color", (0.45, 0.44, 0.43), (-0.12, 0.12)), "stones": (8, 6, 12), "jitter": (0.3, 0.2, 0.5),
    "speckle": (0.5, 0.2, 0.9), "stone_gap": (0.12, 0.06, 0.2)},
    fixed={**rgb_fixed("color2", (0.3, 0.29, 0.3)), "dome": 0.4, "crags": 0.3, "roughness": 0.7})
register_preset("rock/mossy_boulder", "rock", {
    **rgb("color", (0.42, 0.41, 0.38), (-0.12, 0.1)), "lichen": (0.6, 0.3, 1.0), "crags": (0.5, 0.2, 0.8),
    "wet": (0.2, 0.0, 0.5)}, fixed={**rgb_fixed("color2", (0.3, 0.3, 0.28)), "roughness": 0.76, "crag_scale": 0.4})
