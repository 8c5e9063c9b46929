"""Paint: a coloured dielectric coat with orange peel, brush marks, chips down to a substrate, dirt."""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_fixed, rgb_params, tint
from ..noise import Tex, smoothstep
from ..registry import register_class, register_preset

PARAMS = [
    *rgb_params("color", (0.7, 0.1, 0.1), "paint colour"),
    *rgb_params("substrate", (0.55, 0.55, 0.55), "colour under chipped paint"),
    P("roughness", 0.25, 0.02, 0.9, "mean roughness of the coat"),
    P("rough_var", 0.1, 0.0, 0.5, "roughness variation (smudges)"),
    P("specular", 0.04, 0.02, 0.12, "F0 of the coat"),
    P("orange_peel", 0.3, 0.0, 1.0, "fine bumpiness of sprayed paint"),
    P("peel_scale", 0.03, 0.01, 0.1, "orange-peel feature size (texture widths)"),
    P("brush", 0.0, 0.0, 1.0, "depth of brush strokes"),
    P("brush_angle", 0.0, 0.0, 1.5708, "brush direction (rad; half a turn is the same brushing)"),
    P("chips", 0.0, 0.0, 1.0, "area chipped off"),
    P("chip_scale", 0.15, 0.03, 0.5, "chip size (texture widths)"),
    P("dirt", 0.0, 0.0, 1.0, "darkening dirt in blotches"),
    P("color_var", 0.05, 0.0, 0.5, "low-frequency colour unevenness"),
    P("flakes", 0.0, 0.0, 1.0, "metallic flakes (sparkling specular)"),
]


@register_class("paint", PARAMS)
def paint(p: dict, size: int, rng: np.random.Generator):
    """Painted surface."""
    tex = Tex(size, rng)
    base = color_param(p, "color")
    sub = color_param(p, "substrate")
    peel = tex.fbm(p["peel_scale"], beta=3.2)
    brush = tex.fbm(0.4, beta=2.6, aniso=10.0, angle=p["brush_angle"])
    chipf = tex.fbm(p["chip_scale"], beta=3.6)
    dirt, unev = tex.fbm2(0.35, beta=3.0)
    fl = tex.fbm(0.004, beta=0.0)
    smudge = tex.blobs(0.12)

    thr = 2.6 - 3.6 * p["chips"]  # chips=0: none; 1: ~84% of the area
    # the tail of a Gaussian field is never empty: fade chips out entirely as chips -> 0
    chip = smoothstep(thr - 0.04, thr + 0.04, chipf) * min(1.0, 20.0 * p["chips"])
    h = 0.0015 * p["orange_peel"] * peel + 0.0008 * p["brush"] * brush - 0.002 * chip
    col = tint(base, unev, p["color_var"])
    dmask = np.clip(dirt * 0.5 + 0.2, 0, 1) * p["dirt"]
    diff = lerp(col, sub, chip) * (1 - 0.7 * dmask)[..., None]
    sparkle = np.clip(fl - 1.5, 0, None) * p["flakes"]
    spec = lerp(np.full(3, p["specular"], np.float32), 0.6 * base + 0.2, np.clip(sparkle, 0, 1))
    spec = lerp(spec, np.full(3, 0.04, np.float32), chip)
    r = p["roughness"] + p["rough_var"] * 0.5 * smudge + 0.3 * dmask
    r = lerp(r[..., None], np.full(1, 0.7, np.float32), chip)[..., 0]
    return finish(h, 1.0, diff, spec, r)


register_preset("paint/glossy_red", "paint", {
    **rgb("color", (0.75, 0.08, 0.07), (-0.2, 0.2)),
    "roughness": (0.12, 0.05, 0.3), "orange_peel": (0.4, 0.0, 1.0), "peel_scale": (0.03, 0.015, 0.06),
    "rough_var": (0.1, 0.0, 0.3)})
register_preset("paint/chipped_blue", "paint", {
    **rgb("color", (0.15, 0.3, 0.6), (-0.15, 0.15)),
    "chips": (0.35, 0.15, 0.6), "chip_scale": (0.12, 0.05, 0.3), "roughness": (0.35, 0.2, 0.6),
    **rgb("substrate", (0.45, 0.42, 0.4), (-0.2, 0.2)), "dirt": (0.3, 0.0, 0.7)},
    fixed={"orange_peel": 0.2})
register_preset("paint/brushed_white", "paint", {
    **rgb("color", (0.88, 0.87, 0.83), (-0.1, 0.1)),
    "brush": (0.6, 0.2, 1.0), "brush_angle": (0.0, 0.0, 1.57), "roughness": (0.4, 0.2, 0.7),
    "color_var": (0.05, 0.0, 0.2), "dirt": (0.1, 0.0, 0.5)}, fixed={"orange_peel": 0.1})
register_preset("paint/metallic_car", "paint", {
    **rgb("color", (0.1, 0.35, 0.2), (-0.1, 0.3)),
    "flakes": (0.6, 0.2, 1.0), "roughness": (0.15, 0.05, 0.3), "orange_peel": (0.3, 0.0, 0.8),
    "specular": (0.05, 0.03, 0.11)})
register_preset("paint/matte_wall", "paint", {
    **rgb("color", (0.8, 0.75, 0.6), (-0.3, 0.15)),
    "roughness": (0.75, 0.5, 0.9), "orange_peel": (0.8, 0.3, 1.0), "peel_scale": (0.02, 0.01, 0.05),
    "color_var": (0.1, 0.0, 0.3), "dirt": (0.2, 0.0, 0.6), "rough_var": (0.1, 0.0, 0.4)})
register_preset("paint/peeling_green", "paint", {
    **rgb("color", (0.2, 0.45, 0.3), (-0.15, 0.15)),
    "chips": (0.6, 0.4, 0.8), "chip_scale": (0.2, 0.1, 0.4),
    "brush": (0.5, 0.2, 1.0), "roughness": (0.5, 0.3, 0.8), "dirt": (0.4, 0.1, 0.8),
    "color_var": (0.15, 0.0, 0.4)}, fixed=rgb_fixed("substrate", (0.45, 0.33, 0.22)))
