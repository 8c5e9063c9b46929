"""Leather: pebbled cellular grain, wrinkles, pores, worn lighter peaks, medium roughness.

Physical ranges (``PHYSICAL``): dyed leathers' albedo runs from black ~0.02-0.03 to natural veg-tan ~0.5 (linear;
physicallybased.info's measured albedos, and the leather scans of materials-cc0); the finished grain is a
dielectric of F0 ~0.035-0.06 (protein and its wax/lacquer finish, n ~1.5), one F0 over the hide.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_params, slope_scaled, tint
from ..noise import Tex
from ..patterns import worley
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.02, 0.7), "specular": (0.03, 0.06), "roughness": (0.05, 1.0)}

PARAMS = [
    *rgb_params("color", (0.35, 0.18, 0.08), "leather colour"),
    P("color_var", 0.15, 0.0, 0.6, "blotchy colour variation"),
    P("cells", 40, 8, 120, "grain cells across the texture", "int"),
    P("cell_depth", 0.5, 0.0, 1.0, "depth of the creases between cells"),
    P("cell_jitter", 0.9, 0.2, 1.0, "irregularity of the cells"),
    P("wrinkles", 0.3, 0.0, 1.0, "large folds"),
    P("wrinkle_scale", 0.3, 0.08, 0.8, "fold size (texture widths)"),
    P("pores", 0.2, 0.0, 1.0, "fine pores"),
    P("roughness", 0.55, 0.2, 0.9, "mean roughness"),
    P("rough_var", 0.15, 0.0, 0.4, "roughness difference crease vs top"),
    P("wear", 0.2, 0.0, 1.0, "lighter, smoother worn peaks"),
    P("specular", 0.045, 0.035, 0.06, "F0 of the finished grain (uniform)"),
    P("crease_dark", 0.4, 0.0, 0.9, "darkening inside creases"),
]


@register_class("leather", PARAMS)
def leather(p: dict, size: int, rng: np.random.Generator):
    """Tanned leather."""
    tex = Tex(size, rng)
    base = color_param(p, "color")
    f1, f2, _, rnd = worley(tex, p["cells"], p["cell_jitter"])
    wr, blot = tex.fbm2(p["wrinkle_scale"], beta=3.4)
    pore = tex.fbm(0.004, beta=1.0)
    crease = np.clip(1 - (f2 - f1) * 3.0, 0, 1) ** 2  # 1 on cell borders
    dome = np.sqrt(np.clip(1 - f1 * 1.1, 0, 1))
    cw = 1.0 / max(p["cells"], 1)  # cell width: creases scale with the cells
    # folds carry mid-scale relief (a few to ~30 cycles per map); pores are a shallow fine detail
    h = cw * 0.08 * p["cell_depth"] * (dome - crease) + slope_scaled(wr, 0.06 * p["wrinkles"] + 1e-6)
    porem = np.clip(pore - 1.0, 0, None)
    h = h - 0.0003 * p["pores"] * porem
    top = np.clip(wr * 0.5 + dome - 0.6, 0, 1) * p["wear"]
    col = tint(base, blot, p["color_var"]) * (1 - p["crease_dark"] * crease)[..., None]
    col = lerp(col, np.minimum(1, base * 1.8 + 0.03), top * 0.6)
    col = col * (1 - 0.3 * p["pores"] * porem)[..., None]  # pores trap dirt and shadow
    r = p["roughness"] + p["rough_var"] * (crease - 0.3) - 0.25 * top + 0.1 * p["pores"] * porem
    return finish(h, 1.0, col, p["specular"], np.clip(r, 0.05, 1), albedo=PHYSICAL["diffuse"])


register_preset("leather/brown_pebbled", "leather", {
    **rgb("color", (0.4, 0.22, 0.1), (-0.15, 0.15)),
    "cells": (45, 25, 80), "cell_depth": (0.5, 0.2, 0.9), "roughness": (0.55, 0.35, 0.75),
    "color_var": (0.15, 0.0, 0.4), "wear": (0.2, 0.0, 0.6)})
register_preset("leather/black_smooth", "leather", {
    **rgb("color", (0.05, 0.045, 0.04), (-0.03, 0.08)),
    "cells": (90, 60, 120), "cell_depth": (0.2, 0.05, 0.4), "wrinkles": (0.4, 0.1, 0.8),
    "roughness": (0.35, 0.2, 0.55), "wear": (0.3, 0.0, 0.7), "pores": (0.3, 0.0, 0.8)})
register_preset("leather/tan_worn", "leather", {
    **rgb("color", (0.7, 0.45, 0.25), (-0.2, 0.15)),
    "wear": (0.6, 0.3, 1.0), "cells": (35, 20, 60), "cell_depth": (0.4, 0.2, 0.8), "crease_dark": (0.5, 0.2, 0.8),
    "color_var": (0.25, 0.1, 0.5), "roughness": (0.6, 0.4, 0.8), "wrinkle_scale": (0.3, 0.1, 0.6)},
    fixed={"wrinkles": 0.5})
register_preset("leather/croc_green", "leather", {
    **rgb("color", (0.15, 0.25, 0.12), (-0.1, 0.15)),
    "cells": (14, 8, 24), "cell_depth": (0.7, 0.4, 1.0), "cell_jitter": (0.5, 0.2, 0.8),
    "crease_dark": (0.6, 0.3, 0.9), "roughness": (0.4, 0.25, 0.6), "rough_var": (0.2, 0.0, 0.4),
    "specular": (0.05, 0.04, 0.06)})
register_preset("leather/suede_red", "leather", {
    **rgb("color", (0.45, 0.08, 0.06), (-0.15, 0.15)),
    "roughness": (0.85, 0.7, 0.9), "pores": (0.6, 0.2, 1.0), "wrinkles": (0.5, 0.2, 0.9),
    "color_var": (0.2, 0.05, 0.5), "wrinkle_scale": (0.4, 0.15, 0.8)},
    fixed={"cell_depth": 0.08, "cells": 100, "specular": 0.038, "wear": 0.0})
# saddle leather: coarse, deep pebble grain under broad folds, natural tan
register_preset("leather/saddle_coarse", "leather", {
    **rgb("color", (0.62, 0.4, 0.22), (-0.15, 0.12)),
    "cells": (18, 10, 28), "cell_depth": (0.8, 0.5, 1.0), "wrinkles": (0.6, 0.3, 1.0), "wrinkle_scale": (0.2, 0.1, 0.4),
    "roughness": (0.5, 0.35, 0.7), "crease_dark": (0.5, 0.2, 0.8)})
