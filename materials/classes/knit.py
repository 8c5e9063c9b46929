"""Knit and pile textiles: stockinette, rib and garter knits, coarse plain and twill weaves (jute, sisal), loop and
cut pile carpet, felt.

Textile fibres are dielectrics (wool, cotton, jute, nylon: refractive index 1.5-1.56, F0 about 0.04-0.05; a
little lower seen through fuzz), matte (roughness 0.6-1 in the reference set's fabric scans); dyed yarn albedos span
0.02-0.8 (physicallybased.info measured albedo tables). Relief: the stitch, weave or tuft pattern (6-32 across the
texture) carries the slope power; fibre fuzz is a weaker finer layer.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_fixed, rgb_params, tint
from ..heights import at_slope, band_pair, bands
from ..noise import F32, Tex, fbm_pair
from ..patterns import weave, worley
from ..registry import register_class, register_preset

#: linear diffuse, F0 and roughness that every variant keeps (module docstring: sources).
PHYSICAL = {"diffuse": (0.02, 0.85), "specular": (0.025, 0.06), "roughness": (0.5, 1.0)}

PATTERNS = ("stockinette", "rib", "garter", "plain_weave", "twill_weave", "loop_pile", "cut_pile", "felt")

PARAMS = [
    *rgb_params("color", (0.7, 0.65, 0.58), "main yarn colour"),
    *rgb_params("color2", (0.3, 0.3, 0.35), "second yarn colour (stripes, weft)"),
    P("pattern", 0, 0, 7, "structure: " + ", ".join(f"{i} {s}" for i, s in enumerate(PATTERNS)), "int"),
    P("stitches", 12, 6, 32, "stitches / threads / tufts across the texture", "int"),
    P("depth", 0.2, 0.0, 0.45, "RMS slope of the stitch relief"),
    P("fuzz", 0.02, 0.0, 0.06, "RMS slope of the fibre fuzz"),
    P("stripes", 0, 0, 8, "colour stripes (pairs) down the texture", "int"),
    P("color_var", 0.08, 0.0, 0.35, "yarn colour unevenness"),
    P("shadow", 0.4, 0.0, 0.7, "darkening between stitches"),
    # calibrated (#23): reference denim_fabric (materials-cc0): mean roughness 0.81 (the stitch and fuzz terms
    # add about 0.05)
    P("roughness", 0.76, 0.6, 1.0, "roughness"),
    P("sheen", 0.04, 0.025, 0.06, "F0 of the fibres"),
]


def _leg(fx: np.ndarray, t: np.ndarray) -> np.ndarray:
    """One knit stitch's V of two yarn legs; ``t`` runs from -0.4 (top, legs apart) to 1 (bottom, legs meet)."""
    c = 0.08 + 0.34 * (1.0 - t) / 1.4
    d = np.abs(np.abs(fx - 0.5) - c)
    # raised-cosine cross-section: a round yarn's sqrt profile has infinite slope at its edges, which puts most
    # of the slope power into the finest octaves
    prof = np.cos(0.5 * np.pi * np.clip(d / 0.24, 0, 1)) ** 2
    arch = np.sqrt(np.clip(np.sin(np.pi * (t + 0.4) / 1.4), 0, 1))
    return np.where((t >= -0.4) & (t <= 1.0), prof * (0.45 + 0.55 * arch), 0.0)


def _purl(fx: np.ndarray, fy: np.ndarray) -> np.ndarray:
    """A purl bump: a horizontal arc of yarn across the stitch."""
    return np.cos(0.5 * np.pi * np.clip(np.abs(fy - 0.5) / 0.45, 0, 1)) ** 2 * (0.75 + 0.25 * np.cos(2 * np.pi * (fx - 0.5)))


def stitches(tex: Tex, kind: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Knit structure with ``n`` stitches across and round(1.4 n) rows down (wraps).

    Returns:
        height: (H, W) float32 in [0, 1].
        row: (H, W) int32 stitch row (for stripes).
    """
    if kind == 1:
        n += n % 2  # 1x1 rib: knit and purl columns come in pairs
    ny = max(1, int(round(1.4 * n)))
    x = tex.u * n + 0.25
    y = tex.v * ny + 0.3
    col, row = np.floor(x), np.floor(y)
    fx, fy = x - col, y - row
    knit = np.maximum(_leg(fx, fy), _leg(fx, fy - 1.0))
    if kind == 2:  # garter: knit and purl rows alternate
        h = np.where(row % 2 == 0, knit, _purl(fx, fy))
    elif kind == 1:  # rib: purl columns sit back
        h = np.where(col % 2 == 0, knit, 0.55 * _purl(fx, fy))
    else:
        h = knit
    return h.astype(F32), (row.astype(np.int32) % ny)


@register_class("knit", PARAMS)
def knit(p: dict, size: int, rng: np.random.Generator):
    """Knitted, woven and pile textiles."""
    tex = Tex(size, rng)
    c1, c2 = color_param(p, "color"), color_param(p, "color2")
    kind, n = int(round(p["pattern"])), int(round(p["stitches"]))
    fz, unev = band_pair(size, tex.seed(), 48.0, 10.0)
    mot, tuft = fbm_pair(size, tex.seed(), 0.3, 3.0)
    second = np.zeros((size, size), bool)
    if kind <= 2:
        t, row = stitches(tex, kind, n)
        k = int(round(p["stripes"]))
        if k:  # stripes of whole stitch rows: 2k stripes over the rows (rows a multiple of 2k would be exact;
            # rounding the boundary per row keeps every stripe a whole number of rows and the pattern periodic)
            ny = int(row.max()) + 1
            second = (np.floor(row * (2 * k) / ny) % 2).astype(bool)
    elif kind <= 4:
        t, warp_vis, _ = weave(tex, n, "plain" if kind == 3 else "twill", 0.1, 2)
        second = ~warp_vis
    elif kind == 5:  # loop pile: rows of round loops, every other row shifted half a loop
        ny = n + n % 2
        x, y = tex.u * n + 0.25, tex.v * ny + 0.25
        r = np.floor(y)
        fx = (x + 0.5 * (r % 2)) % 1.0
        fy = y - r
        t = np.cos(0.5 * np.pi * np.clip(np.hypot((fx - 0.5) / 0.5, (fy - 0.5) / 0.5), 0, 1)).astype(F32) ** 2
        t = t * (0.85 + 0.3 * np.clip(tuft, -1, 1))
    elif kind == 6:  # cut pile: tufts on a jittered grid, each a rounded cone of its own height
        f1, _, cell, rnd = worley(tex, n, 0.8)
        t = np.clip(1.0 - f1 / 0.7, 0, 1) ** 1.5 * (0.7 + 0.6 * rnd[cell])
    else:  # felt: matted fibres, no structure beyond soft lumps
        t = np.zeros((size, size), F32)
    h = at_slope(t.astype(F32), p["depth"]) if kind < 7 else np.zeros((size, size), F32)
    h = h + at_slope(fz, p["fuzz"])
    h = h + bands(tex, 6.0, 0.02 + (0.04 if kind == 7 else 0.0), 0.0)
    col = np.where(second[..., None], c2, c1)
    col = tint(col, 0.6 * unev + 0.4 * mot, p["color_var"])
    tn = t / max(float(t.max()), 1e-6)
    col = col * (1 - p["shadow"] * (1 - tn) * (kind < 7))[..., None]
    col = col * (1 + 0.1 * np.clip(fz, -2, 2) * p["fuzz"] / 0.06)[..., None]
    r = p["roughness"] + 0.05 * (1 - tn) + 0.03 * fz
    return finish(h, 1.0, np.clip(col, 0.02, 0.85), np.full(3, p["sheen"], F32), np.clip(r, 0.5, 1.0))


register_preset("knit/chunky_wool_cream", "knit", {
    **rgb("color", (0.85, 0.8, 0.7), (-0.12, 0.06)), "stitches": (8, 6, 11), "depth": (0.3, 0.2, 0.42),
    "fuzz": (0.025, 0.01, 0.04), "color_var": (0.06, 0.0, 0.15)}, fixed={"pattern": 0})
register_preset("knit/jersey_grey", "knit", {
    **rgb("color", (0.5, 0.5, 0.52), (-0.15, 0.15)), "stitches": (11, 9, 13), "depth": (0.15, 0.08, 0.25),
    "shadow": (0.3, 0.15, 0.45)}, fixed={"pattern": 0, "fuzz": 0.015})
register_preset("knit/rib_sweater_navy", "knit", {
    **rgb("color", (0.16, 0.2, 0.36), (-0.06, 0.1)), "stitches": (14, 10, 20), "depth": (0.25, 0.15, 0.38),
    "fuzz": (0.02, 0.0, 0.04)}, fixed={"pattern": 1})
register_preset("knit/garter_scarf_red", "knit", {
    **rgb("color", (0.62, 0.12, 0.12), (-0.12, 0.1)), "stitches": (10, 7, 14), "depth": (0.28, 0.18, 0.4),
    "color_var": (0.1, 0.03, 0.2)}, fixed={"pattern": 2})
register_preset("knit/striped_stockinette", "knit", {
    **rgb("color", (0.8, 0.75, 0.65), (-0.12, 0.08)), **rgb("color2", (0.25, 0.35, 0.3), (-0.1, 0.15)),
    "stripes": (3, 1, 6), "stitches": (12, 8, 18), "depth": (0.22, 0.12, 0.35)}, fixed={"pattern": 0})
register_preset("knit/jute_plain_weave", "knit", {
    **rgb("color", (0.62, 0.5, 0.34), (-0.1, 0.08)), "stitches": (10, 6, 16), "depth": (0.3, 0.18, 0.42),
    "fuzz": (0.03, 0.015, 0.05), "color_var": (0.15, 0.05, 0.3)},
    fixed={"pattern": 3, **rgb_fixed("color2", (0.58, 0.47, 0.32))})
register_preset("knit/sisal_twill_mat", "knit", {
    **rgb("color", (0.7, 0.6, 0.42), (-0.12, 0.08)), **rgb("color2", (0.6, 0.5, 0.35), (-0.12, 0.08)),
    "stitches": (12, 8, 18), "depth": (0.28, 0.15, 0.4), "fuzz": (0.025, 0.01, 0.04)}, fixed={"pattern": 4})
register_preset("knit/wool_twill_charcoal", "knit", {
    **rgb("color", (0.25, 0.25, 0.26), (-0.1, 0.1)), **rgb("color2", (0.4, 0.4, 0.4), (-0.1, 0.1)),
    "stitches": (18, 12, 24), "depth": (0.15, 0.08, 0.25)}, fixed={"pattern": 4, "fuzz": 0.02})
register_preset("knit/berber_loop_carpet", "knit", {
    **rgb("color", (0.72, 0.66, 0.56), (-0.15, 0.08)), "stitches": (14, 10, 20), "depth": (0.25, 0.15, 0.38),
    "color_var": (0.15, 0.05, 0.3), "roughness": (0.78, 0.68, 0.9)}, fixed={"pattern": 5})
register_preset("knit/cut_pile_carpet_beige", "knit", {
    **rgb("color", (0.68, 0.6, 0.5), (-0.15, 0.1)), "stitches": (20, 14, 28), "depth": (0.18, 0.1, 0.28),
    "fuzz": (0.03, 0.015, 0.05), "roughness": (0.8, 0.7, 0.92)}, fixed={"pattern": 6})
register_preset("knit/shag_rug_grey", "knit", {
    **rgb("color", (0.55, 0.55, 0.55), (-0.2, 0.15)), "stitches": (10, 7, 14), "depth": (0.35, 0.22, 0.45),
    "fuzz": (0.04, 0.02, 0.06), "shadow": (0.55, 0.4, 0.7)}, fixed={"pattern": 6})
register_preset("knit/wool_felt_green", "knit", {
    **rgb("color", (0.3, 0.42, 0.28), (-0.12, 0.1)), "fuzz": (0.03, 0.015, 0.05), "color_var": (0.1, 0.03, 0.2),
    "roughness": (0.8, 0.7, 0.92)}, fixed={"pattern": 7})
