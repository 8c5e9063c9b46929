"""Wood: planks with growth rings, fibres and pores along the grain, grooves, cupping, saw marks, optional varnish.

Physical ranges (``PHYSICAL``): wood albedo spans dark walnut/wenge ~0.03 to bleached maple ~0.7 (linear;
physicallybased.info's measured albedos and the wood scans of materials-cc0, whose diffuse luminance is
0.05-0.35); cellulose and lacquer are dielectrics of F0 ~0.04-0.05 (n 1.5-1.55). Roughness covers high-gloss
varnish to weathered boards.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_params, slope_scaled, tint
from ..noise import F32, Tex, smoothstep
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.02, 0.75), "specular": (0.035, 0.055), "roughness": (0.03, 1.0)}

PARAMS = [
    *rgb_params("color", (0.75, 0.52, 0.3), "early (light) wood colour"),
    P("late_dark", 0.45, 0.0, 0.85, "darkening of the late-wood rings"),
    P("rings", 12, 3, 40, "growth rings across one plank", "int"),
    P("ring_distort", 0.6, 0.0, 2.0, "waviness of the rings (ring widths)"),
    P("ring_sharp", 0.5, 0.0, 1.0, "sharpness of the ring boundary"),
    P("planks", 4, 1, 12, "planks across the texture (grain runs down the image)", "int"),
    P("plank_gap", 0.004, 0.0, 0.015, "groove between planks (texture widths)"),
    P("plank_var", 0.15, 0.0, 0.5, "colour difference between planks"),
    P("fibres", 0.4, 0.0, 1.0, "depth of the fibre streaks"),
    P("pores", 0.3, 0.0, 1.0, "depth of pores along the grain"),
    P("roughness", 0.5, 0.05, 0.9, "roughness of the wood surface"),
    P("varnish", 0.0, 0.0, 1.0, "glossy varnish coat (lower roughness, slightly higher F0)"),
    P("knots", 0.0, 0.0, 1.0, "dark knot blotches"),
    P("cup", 0.3, 0.0, 1.0, "cupping and uneven laying of the planks"),
    P("saw_marks", 0.0, 0.0, 1.0, "band-saw marks across the grain (rough-sawn timber)"),
    P("ribs", 0, 0, 8, "anti-slip ribs along each plank (decking; 0: none)", "int"),
]


@register_class("wood", PARAMS)
def wood(p: dict, size: int, rng: np.random.Generator):
    """Sawn wood planks."""
    tex = Tex(size, rng)
    early = color_param(p, "color")
    npl = int(round(p["planks"]))
    w1, w2 = tex.fbm2(0.35, beta=3.5, aniso=4.0, angle=np.pi / 2)
    # fibres: fine streaks along the grain in the colour (figure); their relief low-passed across the grain so
    # that it stays at mid scales
    fibc = tex.fbm(0.25, beta=1.6, aniso=30.0, angle=np.pi / 2, detail=0.5 / size)
    pore = tex.fbm(0.1, beta=1.0, aniso=12.0, angle=np.pi / 2)
    kn = tex.blobs(0.05)
    g = tex.sub()
    poff = g.random(12).astype(F32)  # per plank ring phase / colour offsets (fixed count: size-free draws)
    pcol = g.standard_normal(12).astype(F32)
    pshift = g.random(12).astype(F32)
    pcup, ptilt = (g.standard_normal((2, 12))).astype(F32)
    # layers added for #23 draw their seeds after the older ones: the older layers keep their layout
    fib = tex.fbm(0.25, beta=1.6, aniso=8.0, angle=np.pi / 2, detail=0.25)
    saw = tex.fbm(0.5, beta=3.0, aniso=0.15, angle=np.pi / 2, detail=0.2)  # ridges across the grain

    x = tex.u * npl + 0.5  # the seam crosses a plank, not a groove (see patterns.tiles)
    plank = np.floor(x).astype(np.int32)
    fx = x - plank
    rings = int(round(p["rings"]))
    # rings: stripes across the plank, waved by noise; different phase per plank
    ph = fx * rings + p["ring_distort"] * (w1 + 0.3 * w2) + poff[plank % npl] * rings
    ph = ph - np.floor(ph)
    sharp = 0.05 + 0.4 * (1 - p["ring_sharp"])
    late = smoothstep(0.55 - sharp, 0.55 + sharp * 0.3, ph) * (1 - smoothstep(0.9, 1.0, ph))
    knot = np.clip(kn + pshift[plank % npl] - 3.0 + 2.0 * p["knots"], 0, 1) * min(1.0, 20 * p["knots"])
    col = tint(early, pcol[plank % npl] * np.ones_like(fx), p["plank_var"])
    col = col * (1 - p["late_dark"] * late - 0.6 * knot)[..., None]
    col = col * (1 + 0.08 * fibc)[..., None]
    porem = np.clip(pore - 0.8, 0, None)
    col = col * (1 - 0.35 * p["pores"] * porem)[..., None]  # open pores read darker
    edge = np.minimum(fx, 1 - fx) / npl
    gap = p["plank_gap"]
    groove = 1 - smoothstep(0.0, max(gap, 1e-6), edge) if gap > 0 else np.zeros_like(fx)
    # a bevelled (eased) edge twice the gap wide carries the groove's relief at the plank scale, not in 1 px
    bevel = (1 - smoothstep(0.0, 4 * gap + 0.01, edge)) ** 2 if gap > 0 else np.zeros_like(fx)
    pw = 1.0 / npl  # plank width, texture widths
    pid = plank % npl
    shape = p["cup"] * pw * (0.02 * pcup[pid] * (fx - 0.5) ** 2 + 0.01 * ptilt[pid] * (fx - 0.5))
    ribs = int(round(p["ribs"]))
    rib = (np.sin(np.pi * fx * ribs) ** 2 * pw * 0.006) if ribs else 0.0
    # rings and pores are fine detail (56+ cycles per map): kept shallow so mid-scale relief dominates
    h = (slope_scaled(fib, 0.05 * p["fibres"] + 1e-6) - 0.00015 * p["pores"] * porem - 0.0025 * bevel
         + 0.00015 * late + shape + rib + slope_scaled(saw, 0.12 * p["saw_marks"] + 1e-6))
    col = col * (1 - 0.5 * groove - 0.1 * p["saw_marks"] * np.clip(saw, 0, None))[..., None]
    v = p["varnish"]
    r = lerp((p["roughness"] + 0.1 * late)[..., None], np.full(1, 0.08, F32), np.full(fx.shape, v, F32))[..., 0]
    r = r + 0.15 * (1 - v) * porem + 0.1 * p["saw_marks"]
    spec = 0.04 + 0.01 * v  # cellulose, or the lacquer over it: one F0 each
    return finish(h * (1 - 0.6 * v), 1.0, col, spec, np.clip(r, 0.03, 1), albedo=PHYSICAL["diffuse"])


register_preset("wood/oak_planks", "wood", {
    **rgb("color", (0.72, 0.52, 0.3), (-0.15, 0.12)),
    "planks": (4, 2, 8), "rings": (14, 8, 24), "late_dark": (0.4, 0.2, 0.6), "ring_distort": (0.6, 0.2, 1.2),
    "plank_var": (0.15, 0.0, 0.35), "roughness": (0.55, 0.35, 0.75), "pores": (0.4, 0.1, 0.8)})
register_preset("wood/varnished_walnut", "wood", {
    **rgb("color", (0.45, 0.28, 0.16), (-0.1, 0.1)),
    "varnish": (0.8, 0.5, 1.0), "rings": (10, 5, 18), "late_dark": (0.55, 0.3, 0.75), "ring_sharp": (0.4, 0.0, 0.9),
    "planks": (3, 1, 6)}, fixed={"plank_gap": 0.002})
register_preset("wood/pine_board", "wood", {
    **rgb("color", (0.85, 0.68, 0.45), (-0.1, 0.1)),
    "knots": (0.4, 0.1, 0.8), "rings": (8, 4, 14), "ring_sharp": (0.8, 0.4, 1.0), "ring_distort": (1.0, 0.4, 1.8),
    "late_dark": (0.35, 0.15, 0.55), "fibres": (0.5, 0.2, 1.0)}, fixed={"planks": 1, "plank_gap": 0.0})
register_preset("wood/parquet_maple", "wood", {
    **rgb("color", (0.88, 0.72, 0.52), (-0.1, 0.08)),
    "planks": (8, 5, 12), "plank_gap": (0.006, 0.003, 0.015), "plank_var": (0.25, 0.05, 0.5),
    "varnish": (0.5, 0.2, 0.9), "late_dark": (0.2, 0.05, 0.4), "rings": (20, 10, 35)})
register_preset("wood/weathered_grey", "wood", {
    **rgb("color", (0.55, 0.52, 0.48), (-0.15, 0.1)),
    "fibres": (0.8, 0.4, 1.0), "pores": (0.7, 0.3, 1.0), "roughness": (0.8, 0.6, 0.9), "plank_gap": (0.008, 0.003, 0.015),
    "planks": (3, 2, 6), "late_dark": (0.3, 0.1, 0.5), "plank_var": (0.1, 0.0, 0.3)},
    fixed={"ring_distort": 1.0})
register_preset("wood/mahogany_veneer", "wood", {
    **rgb("color", (0.5, 0.2, 0.1), (-0.1, 0.1)),
    "ring_distort": (1.4, 0.8, 2.0), "rings": (25, 15, 40), "varnish": (0.6, 0.3, 1.0), "late_dark": (0.4, 0.2, 0.6)},
    fixed={"planks": 1, "plank_gap": 0.0})
# rough-sawn timber: band-saw ridges across the grain, open and rough, no finish
register_preset("wood/rough_sawn", "wood", {
    **rgb("color", (0.7, 0.56, 0.4), (-0.15, 0.1)),
    "saw_marks": (0.7, 0.4, 1.0), "fibres": (0.7, 0.4, 1.0), "roughness": (0.8, 0.65, 0.9), "planks": (2, 1, 3),
    "rings": (10, 6, 16), "late_dark": (0.3, 0.15, 0.5)}, fixed={"plank_gap": 0.008, "cup": 0.6})
# hardwood decking: anti-slip ribs along every board, wide gaps, weathered brown
register_preset("wood/decking_ribbed", "wood", {
    **rgb("color", (0.55, 0.38, 0.25), (-0.15, 0.12)),
    "ribs": (3, 2, 5), "planks": (4, 3, 6), "plank_gap": (0.012, 0.008, 0.015), "roughness": (0.7, 0.5, 0.85),
    "plank_var": (0.2, 0.05, 0.4), "cup": (0.5, 0.2, 1.0)}, fixed={"rings": 16})
