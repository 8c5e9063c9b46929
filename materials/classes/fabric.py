"""Fabric: woven threads (plain, twill, satin) with fibre fuzz, two yarn colours, stains; rough.

Physical ranges (``PHYSICAL``): dyed textiles' albedo runs from ~0.02 (black) to ~0.8 (bleached cotton) (linear;
physicallybased.info's measured albedos, the fabric scans of materials-cc0); cellulose, wool keratin and polyester
are dielectrics with n 1.5-1.6, F0 0.035-0.06; cloth is rough except satin's floats.
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_params, tint
from ..noise import Tex
from ..patterns import weave
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.02, 0.8), "specular": (0.03, 0.06), "roughness": (0.2, 1.0)}

PARAMS = [
    *rgb_params("warp", (0.2, 0.25, 0.5), "warp yarn colour (threads down the image)"),
    *rgb_params("weft", (0.2, 0.25, 0.5), "weft yarn colour (threads across)"),
    P("threads", 48, 8, 160, "threads across the texture", "int"),
    P("pattern", 0, 0, 2, "weave: 0 plain, 1 twill, 2 satin", "int"),
    P("float_len", 2, 2, 4, "float length of twill/satin", "int"),
    P("gap", 0.15, 0.0, 0.5, "open space between threads"),
    P("depth", 0.5, 0.0, 1.0, "thread relief"),
    P("fuzz", 0.3, 0.0, 1.0, "fibre fuzz (fine noise along threads)"),
    # calibrated (#23): reference denim_fabric (materials-cc0): mean roughness 0.81
    P("roughness", 0.8, 0.4, 1.0, "roughness of the yarn"),
    P("sheen", 0.04, 0.035, 0.06, "F0 of the fibres"),
    P("color_var", 0.1, 0.0, 0.5, "yarn colour unevenness"),
    P("stains", 0.0, 0.0, 1.0, "dark stains"),
]


@register_class("fabric", PARAMS)
def fabric(p: dict, size: int, rng: np.random.Generator):
    """Woven cloth."""
    tex = Tex(size, rng)
    wc = color_param(p, "warp")
    fc = color_param(p, "weft")
    pat = ("plain", "twill", "satin")[int(round(p["pattern"]))]
    h, warp_vis, along = weave(tex, p["threads"], pat, p["gap"], int(round(p["float_len"])))
    fz, unev = tex.fbm2(0.02, beta=1.5)
    st = tex.blobs(0.15)
    tw = 1.0 / max(p["threads"], 1)  # thread width: relief scales with it
    height = tw * 0.35 * p["depth"] * h + 0.0006 * p["fuzz"] * fz
    col = np.where(warp_vis[..., None], wc, fc)
    col = tint(col, unev, p["color_var"]) * (0.55 + 0.45 * h)[..., None]  # shadowed thread sides
    stain = np.clip(st - 1.2, 0, 1) * p["stains"]
    col = col * (1 - 0.6 * stain)[..., None]
    r = p["roughness"] - 0.15 * (h - 0.5) * (1 - p["fuzz"]) + 0.1 * p["fuzz"] * np.abs(fz)
    return finish(height, 1.0, col, p["sheen"], np.clip(r, 0.2, 1), albedo=PHYSICAL["diffuse"])


register_preset("fabric/blue_denim", "fabric", {
    **rgb("warp", (0.15, 0.22, 0.45), (-0.1, 0.15)),
    "threads": (64, 40, 100), "fuzz": (0.5, 0.2, 0.9), "depth": (0.6, 0.3, 0.9), "color_var": (0.2, 0.05, 0.4)},
    fixed={"pattern": 1, "float_len": 2, **{"weft_r": 0.8, "weft_g": 0.8, "weft_b": 0.75}})
register_preset("fabric/linen_plain", "fabric", {
    **rgb("warp", (0.8, 0.75, 0.65), (-0.15, 0.1)), **rgb("weft", (0.78, 0.72, 0.62), (-0.15, 0.1)),
    "threads": (40, 20, 70), "gap": (0.2, 0.05, 0.4), "fuzz": (0.4, 0.1, 0.8), "roughness": (0.8, 0.68, 0.92)},
    fixed={"pattern": 0})
register_preset("fabric/red_satin", "fabric", {
    **rgb("warp", (0.7, 0.05, 0.08), (-0.2, 0.15)),
    "threads": (120, 80, 160), "roughness": (0.5, 0.4, 0.7), "sheen": (0.05, 0.04, 0.06), "fuzz": (0.1, 0.0, 0.3)},
    fixed={"pattern": 2, "float_len": 4, "gap": 0.05, "weft_r": 0.5, "weft_g": 0.03, "weft_b": 0.05})
register_preset("fabric/tweed_check", "fabric", {
    **rgb("warp", (0.35, 0.25, 0.15), (-0.15, 0.15)), **rgb("weft", (0.55, 0.5, 0.4), (-0.15, 0.15)),
    "threads": (24, 12, 40), "depth": (0.8, 0.4, 1.0), "fuzz": (0.7, 0.3, 1.0), "float_len": (2, 2, 4)},
    fixed={"pattern": 1})
register_preset("fabric/canvas_stained", "fabric", {
    **rgb("warp", (0.7, 0.65, 0.5), (-0.15, 0.1)),
    "stains": (0.5, 0.2, 1.0), "threads": (24, 16, 40), "gap": (0.1, 0.0, 0.3), "depth": (0.7, 0.4, 1.0),
    "color_var": (0.15, 0.0, 0.4), "roughness": (0.82, 0.7, 0.94)},
    fixed={"pattern": 0, "weft_r": 0.68, "weft_g": 0.62, "weft_b": 0.48})
# burlap / hessian: coarse open jute plain weave, hairy, very rough
register_preset("fabric/burlap", "fabric", {
    **rgb("warp", (0.62, 0.5, 0.33), (-0.12, 0.1)), **rgb("weft", (0.6, 0.48, 0.31), (-0.12, 0.1)),
    "threads": (16, 10, 24), "gap": (0.35, 0.2, 0.5), "depth": (0.9, 0.6, 1.0), "fuzz": (0.6, 0.3, 0.9),
    "color_var": (0.2, 0.05, 0.4)}, fixed={"pattern": 0, "roughness": 0.85})
