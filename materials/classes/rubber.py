"""Rubber: floor mats and treads (ribs, coin studs, diamond grooves, hole mats, tyre blocks), EPDM and granular
flooring, smooth sheet.

Rubber is a dielectric (refractive index about 1.52: F0 about 0.043). Albedo: carbon-black rubber is among the
darkest common materials (physicallybased.info "Tire", about 0.023 linear); coloured EPDM and latex reach about
0.5. Roughness from the reference set's matte scans (0.6-0.95) down to worn, polished tread tops (about 0.35).
Relief: the tread pattern (4-24 repeats across the texture) carries the slope power; stipple is a weaker finer
layer.
"""
from __future__ import annotations

import numpy as np
from scipy.special import ndtri

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_fixed, rgb_params, tint
from ..heights import at_slope, band_pair, bands
from ..noise import F32, Tex, fbm_pair, smoothstep
from ..registry import register_class, register_preset

#: linear diffuse, F0 and roughness that every variant keeps (module docstring: sources).
PHYSICAL = {"diffuse": (0.01, 0.6), "specular": (0.03, 0.06), "roughness": (0.3, 1.0)}

PATTERNS = ("flat", "ribs", "coins", "diamonds", "holes", "blocks")

PARAMS = [
    *rgb_params("color", (0.16, 0.16, 0.16), "rubber colour"),
    *rgb_params("fleck", (0.6, 0.6, 0.6), "colour of EPDM flecks"),
    P("pattern", 0, 0, 5, "tread: 0 flat, 1 ribs, 2 coin studs, 3 diamond grooves, 4 holes, 5 tyre blocks", "int"),
    P("count", 10, 4, 24, "pattern repeats across the texture", "int"),
    P("depth", 0.25, 0.0, 0.6, "RMS slope of the tread pattern"),
    P("stipple", 0.03, 0.0, 0.12, "RMS slope of the stipple / granular texture"),
    P("flecks", 0.0, 0.0, 0.6, "share of the area covered by coloured flecks"),
    P("wear", 0.0, 0.0, 1.0, "polished raised tops (smoother, a little lighter)"),
    P("dust", 0.0, 0.0, 1.0, "grey dust in the grooves"),
    P("color_var", 0.05, 0.0, 0.3, "colour mottling"),
    # calibrated (#23): no rubber in the reference: moulded and granular rubber floorings are matte, not chalky
    # (presets 0.55-0.8)
    P("roughness", 0.75, 0.45, 1.0, "roughness"),
]


def tread(u: np.ndarray, v: np.ndarray, kind: int, n: int) -> np.ndarray:
    """Tread height in [0, 1] (1 raised) for pattern ``kind`` with ``n`` repeats across; wraps (n integer).

    Args:
        u, v: (H, W) texture coordinates.

    Returns:
        (H, W) float32.
    """
    if kind == 4:
        n += n % 2  # staggered rows come in pairs, so the stagger wraps
    x, y = u * n + 0.25, v * n + 0.25  # a quarter repeat off: the seam does not sit on an edge
    fx, fy = x - np.floor(x), y - np.floor(y)
    if kind == 1:  # ribs running along u, a flat top and rounded shoulders
        return smoothstep(0.42, 0.22, np.abs(fy - 0.5))
    if kind == 2:  # round studs
        return smoothstep(0.36, 0.22, np.hypot(fx - 0.5, fy - 0.5))
    if kind == 3:  # raised diamonds between two sets of diagonal grooves
        a, b = x + y, x - y
        g = np.minimum(np.abs(a - np.floor(a) - 0.5), np.abs(b - np.floor(b) - 0.5))
        return smoothstep(0.05, 0.2, g)
    if kind == 4:  # round holes, odd rows staggered (n rows of holes; stagger wraps as rows come in pairs)
        row = np.floor(y)
        fxs = (x + 0.5 * (row % 2)) % 1.0
        return smoothstep(0.25, 0.36, np.hypot(fxs - 0.5, fy - 0.5))
    if kind == 5:  # tyre blocks: staggered blocks (two per repeat down) with zig-zag sipes across
        row = np.floor(y * 2)
        bx = (x + 0.5 * (row % 2)) % 1.0
        by = y * 2 - row
        groove = np.minimum(np.minimum(bx, 1 - bx), np.minimum(by, 1 - by) * 0.5)
        sipe = np.abs(by - 0.5 - 0.12 * np.abs(((bx * 3) % 1.0) - 0.5))
        return smoothstep(0.03, 0.1, groove) * (1 - 0.6 * smoothstep(0.06, 0.0, sipe))
    return np.zeros_like(u, F32)


@register_class("rubber", PARAMS)
def rubber(p: dict, size: int, rng: np.random.Generator):
    """Rubber mats and treads."""
    tex = Tex(size, rng)
    base, fcol = color_param(p, "color"), color_param(p, "fleck")
    kind, n = int(round(p["pattern"])), int(round(p["count"]))
    t = tread(tex.u, tex.v, kind, n).astype(F32)
    h = at_slope(t, p["depth"]) if kind else np.zeros_like(t)
    h = h + bands(tex, 18.0, p["stipple"], 0.3 * p["stipple"], 48.0)
    fl, fl2 = band_pair(size, tex.seed(), 40.0, 40.0)
    mot, mot2 = fbm_pair(size, tex.seed(), 0.3, 3.0)
    # flecks: the peaks of a band field above the threshold that leaves `flecks` of the area (Gaussian quantile)
    fm = smoothstep(-0.25, 0.25, fl - float(ndtri(1 - p["flecks"]))) if p["flecks"] > 0 else np.zeros_like(t)
    col = tint(base, mot, p["color_var"])
    col = lerp(col, tint(fcol, fl2, 0.2), fm)
    top = t if kind else np.ones_like(t)
    col = col * (1 + 0.25 * p["wear"] * top)[..., None]
    low = (1 - t) if kind not in (0, 4) else (1 - t) * (kind == 4)
    dm = np.clip(p["dust"] * (0.6 * low + 0.25) * (0.8 + 0.4 * mot2), 0, 1)
    col = lerp(col, np.full(3, 0.3, F32), dm * 0.7)
    r = p["roughness"] - 0.35 * p["wear"] * top + 0.15 * dm + 0.03 * mot2
    return finish(h, 1.0, np.clip(col, 0.01, 0.6), np.full(3, 0.043, F32), np.clip(r, 0.3, 1.0))


_BLACK = (0.16, 0.16, 0.16)
register_preset("rubber/tyre_tread", "rubber", {
    **rgb("color", (0.13, 0.13, 0.13), (-0.04, 0.06)), "count": (5, 4, 8), "depth": (0.35, 0.2, 0.5),
    "wear": (0.3, 0.0, 0.7), "dust": (0.2, 0.0, 0.6), "roughness": (0.7, 0.55, 0.85)}, fixed={"pattern": 5})
register_preset("rubber/coin_mat_black", "rubber", {
    **rgb("color", _BLACK, (-0.05, 0.08)), "count": (10, 6, 16), "depth": (0.25, 0.12, 0.4),
    "stipple": (0.03, 0.0, 0.06), "dust": (0.15, 0.0, 0.5)}, fixed={"pattern": 2})
register_preset("rubber/ribbed_runner", "rubber", {
    **rgb("color", (0.2, 0.2, 0.2), (-0.08, 0.1)), "count": (14, 8, 22), "depth": (0.2, 0.1, 0.35),
    "wear": (0.2, 0.0, 0.6), "dust": (0.2, 0.0, 0.6)}, fixed={"pattern": 1})
register_preset("rubber/diamond_tread_mat", "rubber", {
    **rgb("color", _BLACK, (-0.05, 0.08)), "count": (8, 5, 12), "depth": (0.25, 0.12, 0.4),
    "stipple": (0.02, 0.0, 0.05), "wear": (0.2, 0.0, 0.6)}, fixed={"pattern": 3})
register_preset("rubber/gym_floor_epdm", "rubber", {
    **rgb("color", (0.12, 0.12, 0.12), (-0.04, 0.06)), **rgb("fleck", (0.55, 0.55, 0.58), (-0.2, 0.15)),
    "flecks": (0.15, 0.05, 0.3), "stipple": (0.06, 0.03, 0.1), "roughness": (0.78, 0.65, 0.9)})
register_preset("rubber/playground_granules_red", "rubber", {
    **rgb("color", (0.5, 0.18, 0.13), (-0.1, 0.1)),
    "flecks": (0.1, 0.0, 0.25), "stipple": (0.09, 0.05, 0.12), "color_var": (0.1, 0.03, 0.2),
    "roughness": (0.8, 0.68, 0.92)}, fixed=rgb_fixed("fleck", (0.2, 0.2, 0.2)))
register_preset("rubber/yoga_mat_purple", "rubber", {
    **rgb("color", (0.42, 0.3, 0.5), (-0.12, 0.1)), "stipple": (0.04, 0.02, 0.07), "count": (16, 12, 24),
    "depth": (0.04, 0.0, 0.08), "roughness": (0.7, 0.55, 0.85)}, fixed={"pattern": 2})
register_preset("rubber/anti_fatigue_holes", "rubber", {
    **rgb("color", _BLACK, (-0.05, 0.08)), "count": (8, 5, 12), "depth": (0.3, 0.15, 0.45),
    "dust": (0.3, 0.0, 0.7), "stipple": (0.02, 0.0, 0.05)}, fixed={"pattern": 4})
register_preset("rubber/conveyor_belt_worn", "rubber", {
    **rgb("color", (0.18, 0.18, 0.18), (-0.06, 0.08)), "count": (20, 14, 24), "depth": (0.1, 0.04, 0.2),
    "wear": (0.6, 0.3, 1.0), "dust": (0.3, 0.0, 0.7), "color_var": (0.1, 0.0, 0.2)}, fixed={"pattern": 1})
register_preset("rubber/stair_nosing_grey", "rubber", {
    **rgb("color", (0.38, 0.38, 0.37), (-0.1, 0.1)), "count": (10, 6, 14), "depth": (0.3, 0.15, 0.45),
    "dust": (0.2, 0.0, 0.5)}, fixed={"pattern": 1})
register_preset("rubber/studded_floor_blue", "rubber", {
    **rgb("color", (0.2, 0.3, 0.5), (-0.1, 0.1)), "count": (12, 8, 18), "depth": (0.2, 0.1, 0.35),
    "wear": (0.3, 0.0, 0.6), "roughness": (0.7, 0.55, 0.85)}, fixed={"pattern": 2})
register_preset("rubber/latex_sheet", "rubber", {
    **rgb("color", (0.72, 0.6, 0.42), (-0.12, 0.08)), "stipple": (0.015, 0.005, 0.03), "color_var": (0.08, 0.0, 0.2),
    "roughness": (0.55, 0.45, 0.7)}, fixed=rgb_fixed("fleck", (0.6, 0.6, 0.6)))
