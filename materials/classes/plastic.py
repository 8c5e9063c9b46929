"""Plastic: a dielectric (F0 ~ 0.04) with moulded grain, smudges and fine scratches."""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_params, tint
from ..noise import Tex
from ..patterns import scratches
from ..registry import register_class, register_preset

PARAMS = [
    *rgb_params("color", (0.2, 0.4, 0.8), "plastic colour"),
    P("roughness", 0.3, 0.02, 0.9, "mean roughness"),
    P("specular", 0.04, 0.02, 0.10, "F0 (mean; varies with the colour unevenness and scratches)"),
    P("grain", 0.3, 0.0, 1.0, "depth of the moulded stipple texture"),
    P("grain_scale", 0.02, 0.005, 0.08, "stipple size (texture widths)"),
    P("grain_rough", 0.1, 0.0, 0.4, "extra roughness on stipple peaks"),
    P("smudge", 0.1, 0.0, 1.0, "greasy smudges (lower roughness blotches)"),
    P("scratch_count", 0.0, 0.0, 300.0, "number of scratches", "int"),
    P("scratch_depth", 0.5, 0.0, 1.0, "scratch depth and whiteness"),
    P("scratch_angle", 0.5, 0.0, 1.5708, "main scratch direction (rad)"),
    P("color_var", 0.03, 0.0, 0.4, "colour unevenness"),
    P("translucency", 0.0, 0.0, 1.0, "milky lightening of the colour (subsurface look)"),
]


@register_class("plastic", PARAMS)
def plastic(p: dict, size: int, rng: np.random.Generator):
    """Moulded plastic."""
    tex = Tex(size, rng)
    base = color_param(p, "color")
    g = tex.fbm(p["grain_scale"], beta=2.8, detail=p["grain_scale"] * 0.15)
    sm, unev = tex.fbm2(0.2, beta=3.2)
    sc = scratches(tex, p["scratch_count"], 0.15, p["scratch_angle"], 0.4)
    col = tint(base, unev, p["color_var"])
    col = lerp(col, np.minimum(1, base * 0.6 + 0.3), np.full(col.shape[:2], 0.5 * p["translucency"], np.float32))
    sd = sc * p["scratch_depth"]
    h = 0.0012 * p["grain"] * g - 0.0015 * sd
    diff = lerp(col, np.minimum(1, col + 0.25), sd * 0.7)
    r = p["roughness"] + p["grain_rough"] * np.clip(g, 0, None) * 0.5 - 0.25 * p["smudge"] * np.clip(sm, 0, None)
    r = r + 0.35 * sd
    # F0 varies with the moulding's unevenness and is raised in scratches (svgen stats: uniform F0 was narrower
    # than artist materials' -- docs/IMPORT.md "Widened presets")
    spec = p["specular"] * np.clip(1 + 0.35 * unev, 0.4, 1.8) * (1 + 0.5 * sd)
    return finish(h, 1.0, diff, spec[..., None], np.clip(r, 0.02, 1))


register_preset("plastic/glossy_blue", "plastic", {
    **rgb("color", (0.15, 0.35, 0.75), (-0.15, 0.15)),
    "roughness": (0.1, 0.03, 0.25), "smudge": (0.2, 0.0, 0.6), "scratch_count": (60, 10, 200),
    "scratch_depth": (0.4, 0.1, 0.8)}, fixed={"grain": 0.05})
register_preset("plastic/textured_black", "plastic", {
    **rgb("color", (0.06, 0.06, 0.06), (-0.04, 0.1)),
    "roughness": (0.45, 0.3, 0.7), "grain": (0.6, 0.3, 1.0), "grain_scale": (0.015, 0.008, 0.03),
    "grain_rough": (0.15, 0.0, 0.4), "scratch_count": (30, 0, 120)})
register_preset("plastic/toy_yellow", "plastic", {
    **rgb("color", (0.95, 0.75, 0.1), (-0.15, 0.05)),
    "roughness": (0.2, 0.05, 0.4), "color_var": (0.05, 0.0, 0.2), "smudge": (0.3, 0.0, 0.8),
    "translucency": (0.1, 0.0, 0.4)}, fixed={"grain": 0.1})
register_preset("plastic/milky_white", "plastic", {
    **rgb("color", (0.85, 0.85, 0.82), (-0.1, 0.1)),
    "translucency": (0.5, 0.2, 0.9), "roughness": (0.3, 0.15, 0.5), "grain": (0.2, 0.0, 0.5),
    "grain_scale": (0.03, 0.01, 0.06), "smudge": (0.2, 0.0, 0.6)})
register_preset("plastic/scratched_red", "plastic", {
    **rgb("color", (0.7, 0.08, 0.06), (-0.2, 0.15)),
    "scratch_count": (180, 80, 300), "scratch_depth": (0.6, 0.3, 1.0), "scratch_angle": (0.3, 0.0, 1.57),
    "roughness": (0.25, 0.1, 0.5), "grain": (0.2, 0.0, 0.6), "color_var": (0.08, 0.0, 0.3),
    "specular": (0.045, 0.025, 0.09)})
