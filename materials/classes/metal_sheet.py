"""Metal sheet: corrugated, standing-seam and diamond-plate sheet, bare, galvanised, painted or rusted.

Bare metal has a coloured F0 and a near-black diffuse; paint and rust are dielectric layers on top (F0 about 0.04,
coloured diffuse). Ranges: F0 of iron (0.53, 0.51, 0.49), zinc (about 0.66-0.8), aluminium (0.91, 0.92, 0.92) and
dielectric F0 0.02-0.08 from physicallybased.info; rust and paint albedos 0.02-0.9 (physicallybased.info measured
albedos); roughness from the metal/painted-metal scans of the reference set (docs/REALISM.md).
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_fixed, rgb_params
from ..heights import at_slope, bands
from ..noise import F32, Tex, fbm, fbm_pair, smoothstep
from ..patterns import scratches
from ..registry import register_class, register_preset

#: linear diffuse, F0 and roughness that every variant keeps (module docstring: sources).
PHYSICAL = {"diffuse": (0.0, 0.9), "specular": (0.02, 1.0), "roughness": (0.05, 1.0)}

PARAMS = [
    *rgb_params("metal", (0.8, 0.8, 0.8), "F0 of the bare metal"),
    *rgb_params("paint", (0.5, 0.1, 0.08), "paint colour"),
    *rgb_params("rust", (0.42, 0.2, 0.08), "rust colour"),
    P("profile", 0, 0, 3, "sheet shape: 0 flat, 1 sine corrugation, 2 trapezoid ribs, 3 standing seams", "int"),
    P("waves", 12, 4, 32, "corrugations / ribs / seams across the texture", "int"),
    P("wave_slope", 0.25, 0.0, 0.6, "RMS slope of the corrugation"),
    P("lugs", 0.0, 0.0, 1.0, "raised diamond-plate lugs (height)"),
    P("lug_count", 12, 6, 24, "lug rows across the texture", "int"),
    P("dents", 0.03, 0.0, 0.12, "RMS slope of dents and waviness"),
    P("paint", 0.0, 0.0, 1.0, "paint coverage (0 bare metal)"),
    P("chips", 0.0, 0.0, 1.0, "paint worn off in patches"),
    P("rust", 0.0, 0.0, 1.0, "rust coverage"),
    P("streaks", 0.0, 0.0, 1.0, "rust runs down the sheet"),
    P("spangle", 0.0, 0.0, 1.0, "galvanised zinc crystals (patchy roughness and F0)"),
    P("roughness", 0.35, 0.08, 0.8, "roughness of the bare metal"),
    P("paint_rough", 0.45, 0.15, 0.9, "roughness of the paint"),
]


def _profile(u: np.ndarray, kind: int, n: int) -> np.ndarray:
    """Cross-section of the sheet along u (H, W) -> (H, W) float32 in [0, 1]; wraps (n integer)."""
    x = u * n
    f = x - np.floor(x)
    if kind == 1:
        return (0.5 + 0.5 * np.sin(2 * np.pi * x)).astype(F32)
    if kind == 2:  # trapezoid rib: flat top on 30 % of the pitch, ramps of 15 %
        return np.clip((0.5 - np.abs(f - 0.5)) / 0.15 - 1.0, 0, 1).astype(F32) ** 0.7
    if kind == 3:  # standing seam: a narrow raised rib per panel
        return smoothstep(0.15, 0.0, np.abs(f - 0.5)).astype(F32)
    return np.zeros_like(u, F32)


@register_class("metal_sheet", PARAMS)
def metal_sheet(p: dict, size: int, rng: np.random.Generator):
    """Sheet metal."""
    tex = Tex(size, rng)
    f0, paint, rustc = color_param(p, "metal"), color_param(p, "paint"), color_param(p, "rust")
    kind, n = int(round(p["profile"])), int(round(p["waves"]))
    und = bands(tex, 6.0, p["dents"], 0.2 * p["dents"], 40.0)
    # every layer draws its seed; layers a preset switches off skip the work (later layers keep their seeds)
    s_chip, s_rust, s_run, s_spg = tex.seed(), tex.seed(), tex.seed(), tex.seed()
    zero = np.zeros((size, size), F32)
    # low-passed (detail 5 px): the relief of paint edges and rust crust follows these fields, and their finest
    # octaves would put most of the slope power at <= 8 px periods, which the network does not learn (#22)
    chip, chd = fbm_pair(size, s_chip, 0.12, 2.8, detail=5.0 / size) if p["paint"] > 0 or p["rust"] > 0 else (zero, zero)
    rst, rsd = fbm_pair(size, s_rust, 0.2, 2.6, detail=5.0 / size) if p["rust"] > 0 or p["streaks"] > 0 else (zero, zero)
    # a field stretched down v: rust runs from fixings and seams
    run = fbm(size, s_run, 0.3, 2.0, aniso=10.0, angle=np.pi / 2, detail=1.0 / size) if p["streaks"] > 0 else zero
    spg = fbm(size, s_spg, 0.03, 0.0, gauss=True) if p["spangle"] > 0 else zero
    sc = scratches(tex, 30, 0.1, 0.3, 1.2)

    h = np.zeros((size, size), F32)
    if kind and p["wave_slope"] > 0:
        h = h + at_slope(_profile(tex.u, kind, n), p["wave_slope"])
    lug = np.zeros((size, size), F32)
    if p["lugs"] > 0:
        # diamond plate: elongated lugs, alternate rows turned 90 degrees (a herringbone), on an integer grid
        m = int(round(p["lug_count"]))
        x, y = tex.u * m, tex.v * m
        i, j = np.floor(x), np.floor(y)
        fx, fy = x - i - 0.5, y - j - 0.5
        turn = ((i + j) % 2).astype(bool)
        a, b = (fx + fy) / np.sqrt(2), (fx - fy) / np.sqrt(2)
        a, b = np.where(turn, b, a), np.where(turn, a, b)
        lug = smoothstep(1.0, 0.0, np.sqrt((a / 0.42) ** 2 + (b / 0.16) ** 2))  # soft-edged: no pixel steps
        h = h + at_slope(lug, 0.35 * p["lugs"])
    h = h + und
    rough = np.full((size, size), p["roughness"], F32) + 0.05 * sc
    spec = np.broadcast_to(f0, (size, size, 3)).astype(F32) * (1 - 0.15 * sc)[..., None]
    if p["spangle"] > 0:
        rough = rough + 0.12 * p["spangle"] * np.tanh(2 * spg)
        spec = spec * (1 - 0.1 * p["spangle"] * (0.5 + 0.5 * np.tanh(2 * spg)))[..., None]
    diff = np.full((size, size, 3), 0.01, F32)
    # paint: dielectric layer, chipped where the chip field is high (more on raised lugs and ribs: wear)
    pm = np.zeros((size, size), F32)
    if p["paint"] > 0:
        thr = 1.6 - 2.6 * p["chips"]
        worn = smoothstep(thr - 0.2, thr + 0.2, chip + 0.6 * lug + 0.3 * chd) if p["chips"] > 0 else 0.0
        pm = np.clip(min(1.0, 3 * p["paint"]) * (1 - worn), 0, 1).astype(F32)
        pcol = paint * (1 + 0.08 * chd)[..., None]
        diff = lerp(diff, pcol, pm)
        spec = lerp(spec, np.full(3, 0.045, F32), pm)
        rough = lerp(rough[..., None], np.full(1, p["paint_rough"], F32), pm)[..., 0]
        if p["chips"] > 0:  # the paint layer's edge where chipped, as a soft step (a hard one is pixel noise)
            h = h + at_slope(smoothstep(thr - 0.6, thr + 0.6, chip + 0.6 * lug + 0.3 * chd), 0.04)
    rm = np.zeros((size, size), F32)
    if p["rust"] > 0 or p["streaks"] > 0:
        thr = 2.2 - 3.6 * p["rust"]
        rm = smoothstep(thr - 0.4, thr + 0.4, rst + 0.4 * rsd + 0.5 * (1 - pm))
        rm = rm * min(1.0, 10 * p["rust"])
        rm = np.maximum(rm, p["streaks"] * np.clip(1.5 * run - 0.6, 0, 1) * 0.8)
        rcol = rustc * np.exp(0.35 * rsd)[..., None]
        diff = lerp(diff, rcol, rm)
        spec = lerp(spec, np.full(3, 0.035, F32), rm)
        rough = lerp(rough[..., None], np.full(1, 0.85, F32), rm)[..., 0]
        crust = smoothstep(thr - 1.0, thr + 1.0, rst + 0.4 * rsd + 0.5 * (1 - pm)) * (1 + 0.3 * rsd)
        h = h + at_slope(crust, 0.05 * min(1.0, 10 * p["rust"]))  # crust sits on top
    diff = np.clip(diff, 0.0, 0.9)
    return finish(h, 1.0, diff, np.clip(spec, 0.02, 1.0), np.clip(rough, 0.05, 1.0))


_ZINC = (0.85, 0.86, 0.87)
_STEEL = (0.77, 0.76, 0.75)
_ALU = (0.91, 0.92, 0.92)
register_preset("metal_sheet/corrugated_galvanised", "metal_sheet", {
    **rgb("metal", _ZINC, (-0.1, 0.05)), "waves": (14, 8, 24), "wave_slope": (0.3, 0.15, 0.5),
    "spangle": (0.6, 0.2, 1.0), "roughness": (0.3, 0.15, 0.5), "dents": (0.02, 0.0, 0.06)},
    fixed={"profile": 1})
register_preset("metal_sheet/corrugated_rusty", "metal_sheet", {
    **rgb("rust", (0.45, 0.22, 0.09), (-0.12, 0.1)), "waves": (12, 8, 20), "wave_slope": (0.3, 0.15, 0.5),
    "rust": (0.6, 0.3, 0.95), "streaks": (0.3, 0.0, 0.7), "roughness": (0.45, 0.3, 0.7), "dents": (0.04, 0.01, 0.1)},
    fixed={"profile": 1, **rgb_fixed("metal", _STEEL)})
register_preset("metal_sheet/painted_corrugated_red", "metal_sheet", {
    **rgb("paint", (0.55, 0.12, 0.08), (-0.15, 0.1)), "waves": (12, 6, 20), "wave_slope": (0.3, 0.15, 0.5),
    "chips": (0.3, 0.0, 0.7), "rust": (0.15, 0.0, 0.4), "paint_rough": (0.5, 0.3, 0.75)},
    fixed={"profile": 1, "paint": 1.0, **rgb_fixed("metal", _ZINC)})
register_preset("metal_sheet/trapezoid_cladding_grey", "metal_sheet", {
    **rgb("paint", (0.45, 0.47, 0.48), (-0.15, 0.1)), "waves": (8, 5, 14), "wave_slope": (0.35, 0.2, 0.55),
    "paint_rough": (0.4, 0.25, 0.6), "dents": (0.02, 0.0, 0.05), "streaks": (0.1, 0.0, 0.4)},
    fixed={"profile": 2, "paint": 1.0, "chips": 0.0, **rgb_fixed("metal", _ZINC)})
register_preset("metal_sheet/standing_seam_zinc", "metal_sheet", {
    **rgb("metal", (0.7, 0.72, 0.74), (-0.1, 0.1)), "waves": (5, 4, 8), "wave_slope": (0.2, 0.1, 0.35),
    "roughness": (0.5, 0.35, 0.7), "spangle": (0.2, 0.0, 0.5), "dents": (0.03, 0.01, 0.06)},
    fixed={"profile": 3})
register_preset("metal_sheet/diamond_plate_steel", "metal_sheet", {
    **rgb("metal", _STEEL, (-0.1, 0.1)), "lugs": (0.7, 0.4, 1.0), "lug_count": (8, 6, 12),
    "roughness": (0.35, 0.2, 0.55), "rust": (0.1, 0.0, 0.4), "dents": (0.02, 0.0, 0.05)})
register_preset("metal_sheet/diamond_plate_aluminium", "metal_sheet", {
    **rgb("metal", _ALU, (-0.1, 0.0)), "lugs": (0.7, 0.4, 1.0), "lug_count": (9, 6, 14),
    "roughness": (0.25, 0.1, 0.45), "spangle": (0.2, 0.0, 0.5)})
register_preset("metal_sheet/diamond_plate_painted_yellow", "metal_sheet", {
    **rgb("paint", (0.8, 0.6, 0.05), (-0.15, 0.1)), "lugs": (0.7, 0.4, 1.0), "lug_count": (8, 6, 12),
    "chips": (0.5, 0.2, 0.9), "paint_rough": (0.5, 0.3, 0.7)},
    fixed={"paint": 1.0, **rgb_fixed("metal", _STEEL)})
register_preset("metal_sheet/rusted_plate_heavy", "metal_sheet", {
    **rgb("rust", (0.35, 0.16, 0.07), (-0.1, 0.12)), "rust": (0.85, 0.6, 1.0), "dents": (0.06, 0.02, 0.12),
    "roughness": (0.55, 0.35, 0.75)},
    fixed={**rgb_fixed("metal", _STEEL)})
register_preset("metal_sheet/chipped_green_panel", "metal_sheet", {
    **rgb("paint", (0.2, 0.38, 0.25), (-0.1, 0.12)), "chips": (0.55, 0.3, 0.9), "rust": (0.3, 0.0, 0.6),
    "streaks": (0.2, 0.0, 0.6), "dents": (0.04, 0.01, 0.08), "paint_rough": (0.55, 0.35, 0.8)},
    fixed={"paint": 1.0, **rgb_fixed("metal", _STEEL)})
register_preset("metal_sheet/galvanised_flat_spangle", "metal_sheet", {
    **rgb("metal", _ZINC, (-0.1, 0.05)), "spangle": (0.8, 0.4, 1.0), "roughness": (0.25, 0.1, 0.45),
    "dents": (0.03, 0.01, 0.07), "streaks": (0.05, 0.0, 0.3)})
register_preset("metal_sheet/painted_blue_ribs_weathered", "metal_sheet", {
    **rgb("paint", (0.12, 0.22, 0.45), (-0.08, 0.12)), "waves": (10, 6, 16), "wave_slope": (0.3, 0.15, 0.5),
    "chips": (0.35, 0.1, 0.7), "streaks": (0.35, 0.1, 0.7), "rust": (0.2, 0.0, 0.5)},
    fixed={"profile": 2, "paint": 1.0, **rgb_fixed("metal", _STEEL)})
