"""Bark: furrowed and plated trunks (oak, pine, elm, spruce), fibrous strips (redwood, cedar), smooth bark with
lenticels (birch, cherry, beech), peeling camouflage (plane, eucalyptus), lichen.

Bark is a rough dielectric (F0 about 0.04). Albedos from about 0.03 (dark furrows) to about 0.6 (birch) span the
bark and wood entries of the physicallybased.info measured albedo tables and the bark scans of the reference set
(docs/REALISM.md); roughness stays high (0.5-1), a little lower on smooth cherry and beech. Relief: plates and
furrows stretched along the trunk, 4-24 across the texture, carry the slope power; fibres are a weaker layer.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_fixed, rgb_params, tint
from ..heights import at_slope, band_pair, bands
from ..noise import F32, Tex, fbm_pair, smoothstep
from ..patterns import scratches, worley
from ..registry import register_class, register_preset

#: linear diffuse, F0 and roughness that every variant keeps (module docstring: sources).
PHYSICAL = {"diffuse": (0.02, 0.7), "specular": (0.03, 0.05), "roughness": (0.45, 1.0)}

PARAMS = [
    *rgb_params("color", (0.42, 0.36, 0.3), "colour of the bark surface (plates, ridges)"),
    *rgb_params("furrow", (0.18, 0.13, 0.1), "colour deep in the furrows"),
    *rgb_params("inner", (0.65, 0.6, 0.45), "colour of freshly exposed bark where it peels"),
    P("plates", 8, 3, 20, "plates / ridges across the texture", "int"),
    P("stretch", 3.0, 1.0, 6.0, "plates elongated along the trunk (down the image)"),
    P("depth", 0.2, 0.0, 0.45, "RMS slope of plates and furrows"),
    P("furrow_width", 0.2, 0.05, 0.5, "furrow width (share of a plate)"),
    P("fibres", 0.0, 0.0, 0.12, "RMS slope of fibrous strands along the trunk"),
    P("lenticels", 0, 0, 300, "horizontal lenticel dashes", "int"),
    P("peel", 0.0, 0.0, 1.0, "area where outer bark has peeled off"),
    P("lichen", 0.0, 0.0, 1.0, "area covered by grey-green lichen"),
    P("color_var", 0.12, 0.0, 0.4, "colour variation"),
    # calibrated (#23): no bark in the reference: its rough dielectrics (rock, ground) average 0.62-0.69;
    # furrows add up to 0.1
    P("roughness", 0.72, 0.5, 1.0, "roughness"),
]


@register_class("bark", PARAMS)
def bark(p: dict, size: int, rng: np.random.Generator):
    """Tree bark."""
    tex = Tex(size, rng)
    top, low, inner = color_param(p, "color"), color_param(p, "furrow"), color_param(p, "inner")
    n = int(round(p["plates"]))
    # fewer rows than columns: cells (plates) long down the trunk
    f1, f2, cell, rnd = worley(tex, n, 0.9, aspect=1.0 / p["stretch"], enabled=p["depth"] > 0)
    s_fib, s_peel = tex.seed(), tex.seed()
    mot, mot2 = fbm_pair(size, tex.seed(), 0.25, 3.0)
    len_ = scratches(tex, p["lenticels"], 0.04, 0.0, 0.08, width=0.7 / size)
    lich, lich2 = band_pair(size, tex.seed(), 6.0, 30.0)

    if p["depth"] > 0:
        # plate surface: high in the middle of a cell, falling into the furrow at the cell boundary
        plate = smoothstep(0.0, 2.0 * p["furrow_width"], f2 - f1) * (0.8 + 0.4 * rnd[cell])
        fur = 1.0 - smoothstep(0.0, p["furrow_width"], f2 - f1)
    else:
        plate, fur = np.ones((size, size), F32), np.zeros((size, size), F32)
    h = at_slope(plate.astype(F32), p["depth"]) if p["depth"] > 0 else np.zeros((size, size), F32)
    if p["fibres"] > 0:  # strands: a band field stretched down the trunk (slow along v, 16 cycles across u)
        # aniso 4 around 4 cycles: strands about 16 across u, a texture long down v; the steep spectrum keeps the
        # slope power near there instead of spreading it into the finest octaves
        fib, _ = fbm_pair(size, s_fib, 0.25, 6.0, aniso=4.0, angle=np.pi / 2)
        h = h + at_slope(fib, p["fibres"])
    else:
        fib = np.zeros((size, size), F32)
    h = h + bands(tex, 6.0, 0.02, 0.0)  # the trunk's own undulation
    col = tint(top, mot + 0.4 * (rnd[cell] - 0.5) + 0.3 * fib, p["color_var"])
    col = lerp(col, tint(low, mot2, 0.2), fur)
    if p["peel"] > 0:
        pl, pl2 = fbm_pair(size, s_peel, 0.15, 4.5, detail=3.0 / size)
        thr = 1.5 - 3.0 * p["peel"]
        pm = smoothstep(thr - 0.15, thr + 0.15, pl + 0.3 * pl2)
        col = lerp(col, tint(inner, pl2, 0.2), pm)
        h = h - at_slope(smoothstep(thr - 0.6, thr + 0.6, pl + 0.3 * pl2), 0.03)  # peeled areas sit lower
    lm = smoothstep(1.6 - 3.0 * p["lichen"], 2.2 - 3.0 * p["lichen"], lich + 0.3 * lich2) * min(1.0, 10 * p["lichen"])
    col = lerp(col, np.array([0.32, 0.36, 0.26], F32) * (1 + 0.2 * lich2)[..., None], lm * (1 - fur))
    col = col * (1 - 0.6 * len_)[..., None]
    h = h + at_slope(lm, 0.02 * p["lichen"]) - 0.0004 * len_
    r = p["roughness"] + 0.1 * fur + 0.05 * lm
    return finish(h, 1.0, np.clip(col, 0.02, 0.7), np.full(3, 0.04, F32), np.clip(r, 0.45, 1.0))


register_preset("bark/oak_furrowed", "bark", {
    **rgb("color", (0.42, 0.38, 0.33), (-0.12, 0.1)), "plates": (8, 5, 12), "stretch": (3.5, 2.5, 5.0),
    "depth": (0.25, 0.15, 0.4), "furrow_width": (0.25, 0.15, 0.4), "color_var": (0.15, 0.05, 0.3)})
register_preset("bark/pine_plates", "bark", {
    **rgb("color", (0.55, 0.38, 0.26), (-0.12, 0.1)),
    "plates": (6, 4, 9), "stretch": (1.8, 1.2, 2.6), "depth": (0.25, 0.15, 0.4), "furrow_width": (0.15, 0.08, 0.25)},
    fixed=rgb_fixed("furrow", (0.15, 0.1, 0.07)))
register_preset("bark/birch_white", "bark", {
    **rgb("color", (0.85, 0.83, 0.78), (-0.1, 0.05)), "lenticels": (120, 60, 220), "color_var": (0.1, 0.03, 0.2),
    "roughness": (0.7, 0.55, 0.85)},
    fixed={"depth": 0.04, "plates": 5, "stretch": 1.5, "furrow_width": 0.06, **rgb_fixed("furrow", (0.12, 0.11, 0.1))})
register_preset("bark/beech_smooth", "bark", {
    **rgb("color", (0.55, 0.55, 0.52), (-0.12, 0.08)), "color_var": (0.15, 0.05, 0.3), "lichen": (0.2, 0.0, 0.5),
    "roughness": (0.7, 0.55, 0.85)}, fixed={"depth": 0.0})
register_preset("bark/redwood_fibrous", "bark", {
    **rgb("color", (0.55, 0.32, 0.22), (-0.12, 0.1)), "fibres": (0.08, 0.04, 0.12), "plates": (10, 6, 16),
    "stretch": (5.0, 3.5, 6.0), "depth": (0.15, 0.08, 0.25)}, fixed={"furrow_width": 0.15})
register_preset("bark/cherry_banded", "bark", {
    **rgb("color", (0.45, 0.27, 0.22), (-0.1, 0.08)), "lenticels": (160, 80, 260), "roughness": (0.6, 0.5, 0.75),
    "color_var": (0.1, 0.03, 0.2)}, fixed={"depth": 0.03, "plates": 4, "stretch": 1.0, "furrow_width": 0.05})
register_preset("bark/plane_tree_camo", "bark", {
    **rgb("color", (0.5, 0.5, 0.42), (-0.1, 0.08)), **rgb("inner", (0.75, 0.72, 0.55), (-0.1, 0.08)),
    "peel": (0.5, 0.3, 0.75), "roughness": (0.75, 0.6, 0.9)}, fixed={"depth": 0.0, "color_var": 0.1})
register_preset("bark/eucalyptus_peeling", "bark", {
    **rgb("color", (0.62, 0.55, 0.48), (-0.12, 0.08)), **rgb("inner", (0.78, 0.7, 0.55), (-0.12, 0.08)),
    "peel": (0.6, 0.35, 0.85), "fibres": (0.03, 0.0, 0.06), "roughness": (0.75, 0.6, 0.9)},
    fixed={"depth": 0.0, "color_var": 0.12})
register_preset("bark/mossy_oak", "bark", {
    **rgb("color", (0.38, 0.35, 0.3), (-0.1, 0.08)), "lichen": (0.55, 0.3, 0.85), "plates": (8, 5, 12),
    "depth": (0.25, 0.15, 0.4), "stretch": (3.5, 2.5, 5.0)}, fixed={"furrow_width": 0.25})
register_preset("bark/cedar_strips", "bark", {
    **rgb("color", (0.5, 0.38, 0.3), (-0.12, 0.1)), "fibres": (0.1, 0.06, 0.12), "plates": (9, 6, 12),
    "stretch": (4.5, 3.0, 6.0), "depth": (0.12, 0.06, 0.2), "peel": (0.2, 0.0, 0.45)},
    fixed={"furrow_width": 0.2})
register_preset("bark/elm_deep_furrows", "bark", {
    **rgb("color", (0.35, 0.3, 0.26), (-0.1, 0.1)),
    "plates": (6, 4, 9), "stretch": (4.5, 3.0, 6.0), "depth": (0.35, 0.22, 0.45), "furrow_width": (0.35, 0.2, 0.5)},
    fixed=rgb_fixed("furrow", (0.1, 0.08, 0.06)))
register_preset("bark/spruce_scaly", "bark", {
    **rgb("color", (0.45, 0.33, 0.26), (-0.1, 0.1)), "plates": (10, 7, 14), "stretch": (1.3, 1.0, 1.8),
    "depth": (0.18, 0.1, 0.3), "furrow_width": (0.2, 0.12, 0.3), "lichen": (0.15, 0.0, 0.4)})
