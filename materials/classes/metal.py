"""Metal: coloured high specular, near-black diffuse; brushing, scratches, hammer dents, oxide.

Physical ranges (``PHYSICAL``): bare metals' F0 (physicallybased.info: iron 0.53-0.56, aluminium 0.91, copper
0.95/0.64/0.54, gold 1.0/0.78/0.34) with a near-black diffuse; rust and patina are dielectrics (F0 0.04) whose
albedo reaches ~0.45 (light verdigris), so the class's diffuse range tops out there and its F0 range starts at the
oxides' 0.04 (minus a margin).
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_fixed, rgb_params
from ..noise import Tex, smoothstep
from ..patterns import scratches, worley
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.0, 0.45), "specular": (0.03, 1.0), "roughness": (0.02, 1.0)}

PARAMS = [
    *rgb_params("metal", (0.91, 0.92, 0.92), "specular colour F0 of the bare metal"),
    *rgb_params("oxide", (0.35, 0.15, 0.06), "colour of rust / patina"),
    P("roughness", 0.25, 0.02, 0.8, "roughness of the bare metal"),
    P("brushed", 0.0, 0.0, 1.0, "strength of directional brushing"),
    P("brush_angle", 0.0, 0.0, 1.5708, "brushing direction (rad)"),
    P("scratch_count", 0.0, 0.0, 400.0, "number of scratches", "int"),
    P("scratch_depth", 0.5, 0.0, 1.0, "scratch depth"),
    P("hammered", 0.0, 0.0, 1.0, "depth of hammer dents"),
    P("dent_count", 12, 4, 40, "hammer dents across the texture", "int"),
    P("oxide", 0.0, 0.0, 1.0, "area covered by rust / patina"),
    P("oxide_scale", 0.2, 0.05, 0.6, "size of oxide patches (texture widths)"),
    P("diffuse", 0.02, 0.0, 0.1, "residual diffuse albedo of the bare metal"),
    P("rough_var", 0.1, 0.0, 0.4, "roughness variation (fingerprints, wear)"),
]


@register_class("metal", PARAMS)
def metal(p: dict, size: int, rng: np.random.Generator):
    """Bare or weathered metal."""
    tex = Tex(size, rng)
    f0 = color_param(p, "metal")
    ox = color_param(p, "oxide")
    br = tex.fbm(0.5, beta=2.2, aniso=25.0, angle=p["brush_angle"], detail=0.6 / size)
    sc = scratches(tex, p["scratch_count"], 0.2, p["brush_angle"], 0.6)
    f1, _, _, _ = worley(tex, p["dent_count"], 1.0, enabled=p["hammered"] > 0)
    oxf, oxd = tex.fbm2(p["oxide_scale"], beta=3.0)
    rv = tex.blobs(0.15)

    thr = 2.5 - 3.5 * p["oxide"]
    om = smoothstep(thr - 0.3, thr + 0.3, oxf + 0.25 * oxd) * min(1.0, 20 * p["oxide"])
    dent = (f1 * f1) / max(p["dent_count"], 1)  # paraboloid dents, scaled with dent size
    h = 0.25 * p["hammered"] * dent + 0.0002 * p["brushed"] * br - 0.001 * p["scratch_depth"] * sc
    h = h + 0.002 * om * (0.5 + 0.5 * oxd)  # oxide crust sits on top
    r = p["roughness"] + 0.15 * p["brushed"] * np.abs(br) * 0.5 + p["rough_var"] * 0.5 * rv
    r = r + 0.25 * p["scratch_depth"] * sc
    r = lerp(r[..., None], np.full(1, 0.85, np.float32), om)[..., 0]
    diff = lerp(np.full(3, p["diffuse"], np.float32) * np.ones_like(h)[..., None], ox * (0.8 + 0.2 * oxd[..., None]), om)
    spec = lerp(f0 * (1 - 0.15 * sc[..., None] * p["scratch_depth"]), np.full(3, 0.04, np.float32), om)
    return finish(h, 1.0, diff, spec, np.clip(r, 0.02, 1))


register_preset("metal/brushed_steel", "metal", {
    **rgb("metal", (0.78, 0.78, 0.8), (-0.15, 0.1)),
    "brushed": (0.8, 0.4, 1.0), "brush_angle": (0.0, 0.0, 1.57), "roughness": (0.3, 0.15, 0.5),
    "scratch_count": (40, 0, 150), "rough_var": (0.1, 0.0, 0.3)})
register_preset("metal/polished_gold", "metal", {
    **rgb("metal", (1.0, 0.86, 0.57), (-0.1, 0.0)),
    "roughness": (0.12, 0.03, 0.3), "scratch_count": (80, 10, 250), "scratch_depth": (0.3, 0.1, 0.7),
    "rough_var": (0.15, 0.0, 0.4)})
register_preset("metal/hammered_copper", "metal", {
    **rgb("metal", (0.96, 0.64, 0.54), (-0.1, 0.04)),
    "hammered": (0.7, 0.3, 1.0), "dent_count": (14, 6, 30), "roughness": (0.25, 0.1, 0.45),
    "oxide": (0.15, 0.0, 0.45), "oxide_scale": (0.15, 0.05, 0.4)},
    fixed=rgb_fixed("oxide", (0.2, 0.45, 0.35)))
register_preset("metal/rusty_iron", "metal", {
    **rgb("metal", (0.77, 0.78, 0.78), (-0.1, 0.1)),
    "oxide": (0.55, 0.3, 0.85), "oxide_scale": (0.2, 0.08, 0.5), **rgb("oxide", (0.42, 0.18, 0.07), (-0.07, 0.2)),
    "roughness": (0.45, 0.25, 0.7), "scratch_count": (30, 0, 120)},
    fixed={"diffuse": 0.03})
register_preset("metal/aluminium_plate", "metal", {
    **rgb("metal", (0.91, 0.92, 0.92), (-0.1, 0.0)),
    "roughness": (0.35, 0.2, 0.6), "brushed": (0.3, 0.0, 0.8), "rough_var": (0.2, 0.0, 0.4),
    "scratch_count": (120, 40, 300), "scratch_depth": (0.5, 0.2, 0.9), "diffuse": (0.03, 0.0, 0.08)})
register_preset("metal/bronze_patina", "metal", {
    **rgb("metal", (0.8, 0.55, 0.35), (-0.1, 0.1)),
    "oxide": (0.45, 0.2, 0.8), **rgb("oxide", (0.3, 0.6, 0.5), (-0.1, 0.1)), "oxide_scale": (0.12, 0.05, 0.3),
    "roughness": (0.3, 0.15, 0.55), "hammered": (0.2, 0.0, 0.5)})
# hammered steel: dense overlapping dents from a planishing hammer, satin
register_preset("metal/hammered_steel", "metal", {
    **rgb("metal", (0.72, 0.72, 0.74), (-0.12, 0.1)),
    "hammered": (0.8, 0.5, 1.0), "dent_count": (24, 16, 36), "roughness": (0.3, 0.15, 0.5), "rough_var": (0.15, 0.0, 0.3),
    "scratch_count": (20, 0, 80)})
