"""Leather: pebbled cellular grain, wrinkles, pores, worn lighter peaks, medium roughness."""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_params, tint
from ..noise import Tex
from ..patterns import worley
from ..registry import register_class, register_preset

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
    P("specular", 0.04, 0.02, 0.10, "F0 (mean; lower in creases, higher on worn tops)"),
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
    h = cw * 0.08 * p["cell_depth"] * (dome - crease) + 0.004 * p["wrinkles"] * wr
    porem = np.clip(pore - 1.0, 0, None)
    h = h - 0.0008 * p["pores"] * porem
    top = np.clip(wr * 0.5 + dome - 0.6, 0, 1) * p["wear"]
    col = tint(base, blot, p["color_var"]) * (1 - p["crease_dark"] * crease)[..., None]
    col = lerp(col, np.minimum(1, base * 1.8 + 0.03), top * 0.6)
    col = col * (1 - 0.3 * p["pores"] * porem)[..., None]  # pores trap dirt and shadow
    r = p["roughness"] + p["rough_var"] * (crease - 0.3) - 0.25 * top + 0.1 * p["pores"] * porem
    spec = p["specular"] * np.clip(1 + 0.3 * blot, 0.4, 1.8) * (1 - 0.4 * crease) * (1 + 0.6 * top)
    return finish(h, 1.0, col, spec[..., None], np.clip(r, 0.05, 1))


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
    "specular": (0.05, 0.03, 0.09)})
register_preset("leather/suede_red", "leather", {
    **rgb("color", (0.45, 0.08, 0.06), (-0.15, 0.15)),
    "roughness": (0.85, 0.7, 0.9), "pores": (0.6, 0.2, 1.0), "wrinkles": (0.5, 0.2, 0.9),
    "color_var": (0.2, 0.05, 0.5), "wrinkle_scale": (0.4, 0.15, 0.8)},
    fixed={"cell_depth": 0.08, "cells": 100, "specular": 0.025, "wear": 0.0})
