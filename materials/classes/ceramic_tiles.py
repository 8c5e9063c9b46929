"""Ceramic tiles: glazed tiles (or bricks) in a grid with grout, bevels, uneven tilt, crazing, dirt.

Physical ranges (``PHYSICAL``): glazes are glasses (n ~1.5-1.6, F0 0.04-0.05), grout and unglazed body ~0.03;
albedo from black glaze ~0.02 to white glaze ~0.85 (linear; physicallybased.info's measured albedos, the tile
scans of materials-cc0).
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_fixed, rgb_params, tint
from ..noise import F32, Tex
from ..patterns import tiles, worley
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.02, 0.85), "specular": (0.025, 0.06), "roughness": (0.02, 1.0)}

PARAMS = [
    *rgb_params("color", (0.9, 0.9, 0.88), "tile glaze colour"),
    *rgb_params("color2", (0.1, 0.1, 0.12), "second tile colour (checker)"),
    *rgb_params("grout", (0.6, 0.58, 0.55), "grout colour"),
    P("tiles_x", 4, 1, 24, "tiles across the texture", "int"),
    P("tiles_y", 4, 1, 24, "tile rows down the texture", "int"),
    P("stagger", 0.0, 0.0, 0.5, "offset of every other row (0.5: running bond)"),
    P("gap", 0.012, 0.002, 0.04, "grout width (texture widths)"),
    P("bevel", 0.01, 0.001, 0.04, "rounded tile edge (texture widths)"),
    P("checker", 0.0, 0.0, 1.0, "alternate tiles in color2"),
    P("tile_var", 0.05, 0.0, 0.4, "colour variation between tiles"),
    P("tilt", 0.3, 0.0, 1.0, "uneven laying (tilt of each tile)"),
    P("glaze_rough", 0.1, 0.02, 0.8, "roughness of the glaze"),
    P("grout_rough", 0.9, 0.5, 1.0, "roughness of the grout"),
    P("crazing", 0.0, 0.0, 1.0, "fine cracks in the glaze"),
    P("dirt", 0.1, 0.0, 1.0, "dirt in the grout and tile corners"),
    P("surface", 0.2, 0.0, 1.0, "waviness of the glaze"),
]


@register_class("ceramic_tiles", PARAMS)
def ceramic_tiles(p: dict, size: int, rng: np.random.Generator):
    """Glazed ceramic tiles."""
    tex = Tex(size, rng)
    c1, c2, cg = color_param(p, "color"), color_param(p, "color2"), color_param(p, "grout")
    t = tiles(tex, p["tiles_x"], p["tiles_y"], p["stagger"], p["gap"], p["bevel"])
    g = tex.sub()
    n_max = 24 * 26
    tv = g.standard_normal(n_max).astype(F32)
    tx, ty = (g.standard_normal((2, n_max)) * 0.004).astype(F32)
    wav, dirtn = tex.fbm2(0.15, beta=3.4)
    f1, f2, _, _ = worley(tex, 18, 1.0, enabled=p["crazing"] > 0)
    tid = t["id"]
    nx, ny = t["nx"], t["ny"]
    row, col_i = tid // nx, tid % nx
    chk = ((row + col_i) % 2 == 1).astype(F32) * p["checker"]
    tile_h = t["height"]
    tilt = p["tilt"] * (tx[tid] * (t["fx"] - 0.5) + ty[tid] * (t["fy"] - 0.5)) * tile_h
    crack = np.clip(1 - (f2 - f1) * 12, 0, 1) * p["crazing"] * tile_h
    h = 0.004 * tile_h + tilt + 0.0005 * p["surface"] * wav * tile_h - 0.0004 * crack
    glaze = tint(lerp(np.broadcast_to(c1, tile_h.shape + (3,)), c2, chk), tv[tid] * np.ones_like(tile_h), p["tile_var"])
    grime = np.clip(0.5 + 0.5 * dirtn, 0, 1) * p["dirt"]
    gr = cg * (1 - 0.6 * grime)[..., None]
    diff = lerp(gr, glaze, tile_h) * (1 - 0.3 * crack)[..., None]
    r = lerp(np.full(1, p["grout_rough"], F32) * np.ones_like(tile_h)[..., None],
             (p["glaze_rough"] + 0.3 * crack)[..., None], tile_h)[..., 0]
    spec = 0.03 + 0.02 * tile_h
    return finish(h, 1.0, diff, spec[..., None], np.clip(r, 0.02, 1), albedo=PHYSICAL["diffuse"])


register_preset("ceramic_tiles/white_bathroom", "ceramic_tiles", {
    **rgb("color", (0.92, 0.92, 0.9), (-0.1, 0.05)),
    "tiles_x": (4, 2, 8), "gap": (0.01, 0.005, 0.02), "tilt": (0.3, 0.0, 0.8), "glaze_rough": (0.08, 0.03, 0.2),
    "dirt": (0.2, 0.0, 0.6), "bevel": (0.01, 0.004, 0.02)}, fixed={"tiles_y": 4})
register_preset("ceramic_tiles/terracotta", "ceramic_tiles", {
    **rgb("color", (0.72, 0.38, 0.22), (-0.15, 0.1)),
    "tile_var": (0.15, 0.05, 0.35), "glaze_rough": (0.65, 0.45, 0.8), "surface": (0.6, 0.2, 1.0),
    "tiles_x": (3, 2, 5), "tiles_y": (3, 2, 5), "gap": (0.02, 0.01, 0.035)},
    fixed={"grout_r": 0.55, "grout_g": 0.52, "grout_b": 0.48, "tilt": 0.5})
register_preset("ceramic_tiles/subway_green", "ceramic_tiles", {
    **rgb("color", (0.3, 0.55, 0.45), (-0.15, 0.15)),
    "tiles_x": (4, 2, 6), "tiles_y": (8, 4, 12), "stagger": (0.5, 0.25, 0.5), "bevel": (0.015, 0.005, 0.03),
    "tile_var": (0.08, 0.0, 0.25), "crazing": (0.3, 0.0, 0.8), "glaze_rough": (0.1, 0.03, 0.25)})
register_preset("ceramic_tiles/checker_floor", "ceramic_tiles", {
    **rgb("color", (0.9, 0.9, 0.88), (-0.1, 0.05)), **rgb("color2", (0.08, 0.08, 0.09), (-0.05, 0.15)),
    "checker": (1.0, 0.5, 1.0), "tiles_x": (6, 4, 10), "glaze_rough": (0.2, 0.05, 0.4), "dirt": (0.3, 0.0, 0.7)},
    fixed={"tiles_y": 6, "gap": 0.006})
register_preset("ceramic_tiles/mosaic_blue", "ceramic_tiles", {
    **rgb("color", (0.15, 0.4, 0.7), (-0.1, 0.15)),
    "tiles_x": (16, 10, 24), "tiles_y": (16, 10, 24), "tile_var": (0.25, 0.1, 0.4), "gap": (0.006, 0.003, 0.01),
    "tilt": (0.6, 0.2, 1.0), "glaze_rough": (0.15, 0.05, 0.35)}, fixed={"bevel": 0.004})
register_preset("ceramic_tiles/red_brick", "ceramic_tiles", {
    **rgb("color", (0.55, 0.22, 0.14), (-0.15, 0.12)), **rgb("grout", (0.7, 0.68, 0.62), (-0.2, 0.1)),
    "tiles_y": (10, 6, 14), "gap": (0.015, 0.008, 0.03), "tile_var": (0.2, 0.05, 0.4), "surface": (0.8, 0.4, 1.0),
    "glaze_rough": (0.75, 0.6, 0.8)}, fixed={"tiles_x": 4, "stagger": 0.5, "tilt": 0.6, "bevel": 0.006})
# zellige: hand-made glazed tiles, wavy and tilted each its own way, glossy, strong colour variation
register_preset("ceramic_tiles/zellige_green", "ceramic_tiles", {
    **rgb("color", (0.2, 0.42, 0.36), (-0.1, 0.12)),
    "tiles_x": (8, 6, 12), "tile_var": (0.3, 0.15, 0.4), "tilt": (0.9, 0.6, 1.0), "surface": (0.9, 0.6, 1.0),
    "glaze_rough": (0.08, 0.03, 0.2), "gap": (0.006, 0.004, 0.01)}, fixed={"tiles_y": 8, "bevel": 0.006})
