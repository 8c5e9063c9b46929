"""Stone: marble veins, granite speckle, cobbles/flagstones (cells), layered slate; rough dielectric.

Physical ranges (``PHYSICAL``): rock-forming minerals are dielectrics with n 1.5-1.7 (calcite 1.6, quartz 1.55):
F0 0.04-0.06, one F0 per stone; albedo from basalt/slate ~0.03 to white marble ~0.85 (linear; physicallybased.info's
measured albedos, the stone scans of materials-cc0).
"""
from __future__ import annotations

import numpy as np

from ..color import color_param
from ..compose import P, finish, lerp, rgb, rgb_fixed, rgb_params, tint
from ..noise import Tex, smoothstep, warp
from ..patterns import worley
from ..registry import register_class, register_preset

PHYSICAL = {"diffuse": (0.02, 0.85), "specular": (0.03, 0.06), "roughness": (0.03, 1.0)}

PARAMS = [
    *rgb_params("color", (0.55, 0.53, 0.5), "main stone colour"),
    *rgb_params("vein", (0.2, 0.2, 0.22), "vein / speckle colour"),
    P("veins", 0.0, 0.0, 1.0, "marble veins amount"),
    P("vein_scale", 0.4, 0.1, 1.0, "vein pattern size (texture widths)"),
    P("turbulence", 0.5, 0.0, 1.5, "domain warp of the veins"),
    P("speckle", 0.0, 0.0, 1.0, "granite speckle amount"),
    P("speckle_size", 0.008, 0.002, 0.03, "speckle grain size (texture widths)"),
    P("cells", 0, 0, 16, "stones across the texture (0: one continuous slab)", "int"),
    P("cell_gap", 0.03, 0.0, 0.1, "joint width between stones (cell widths)"),
    P("cell_round", 0.5, 0.0, 1.0, "dome of each stone"),
    P("cell_var", 0.15, 0.0, 0.5, "colour variation between stones"),
    P("bump", 0.4, 0.0, 1.0, "surface roughness relief"),
    P("bump_scale", 0.1, 0.02, 0.4, "relief feature size (texture widths)"),
    P("layers", 0.0, 0.0, 1.0, "sedimentary layering (slate)"),
    P("roughness", 0.7, 0.05, 1.0, "roughness"),
    P("polish", 0.0, 0.0, 1.0, "polished finish (lower roughness, flatter)"),
    *rgb_params("joint", (0.3, 0.28, 0.25), "colour of the joints between stones"),
]


@register_class("stone", PARAMS)
def stone(p: dict, size: int, rng: np.random.Generator):
    """Natural stone."""
    tex = Tex(size, rng)
    base, vein, joint = color_param(p, "color"), color_param(p, "vein"), color_param(p, "joint")
    t1, t2 = tex.fbm2(p["vein_scale"], beta=3.2)
    vf = tex.fbm(p["vein_scale"], beta=3.6)
    sp, spc = tex.fbm2(p["speckle_size"] * 4, beta=0.5)
    b1, b2 = tex.fbm2(p["bump_scale"], beta=3.4)  # steeper than 3: the relief's slopes sit at mid scales
    lay = tex.fbm(0.8, beta=3.0, aniso=12.0, angle=0.3)
    nc = int(round(p["cells"]))
    f1, f2, cid, rnd = worley(tex, max(nc, 1), 0.85, enabled=nc > 0)

    tb = 0.06 * p["turbulence"] * p["vein_scale"]
    vw = warp(vf, tb * t1, tb * t2)
    vline = np.exp(-(vw * 6.0) ** 2) * p["veins"]  # thin bright/dark lines at zero crossings
    spk = smoothstep(1.0, 1.4, sp) * p["speckle"]
    col = tint(base, 0.5 * b2 + 0.5 * lay * p["layers"], 0.15)
    col = lerp(col, vein, np.clip(vline + spk, 0, 1))
    col = col * (1 + 0.25 * spc * p["speckle"] * 0.3)[..., None]
    if nc > 0:
        d = f2 - f1
        joint_m = 1 - smoothstep(p["cell_gap"], p["cell_gap"] + 0.05, d)
        dome = p["cell_round"] * np.sqrt(np.clip(d * 2.0, 0, 1)) / nc * 0.3
        col = tint(col, (rnd[cid] - 0.5) * 2, p["cell_var"])
        col = lerp(col, joint, joint_m)
    else:
        joint_m = np.zeros_like(f1)
        dome = np.zeros_like(f1)
    flat = 1 - 0.8 * p["polish"]
    h = flat * (0.003 * p["bump"] * p["bump_scale"] * 10 * b1 + 0.002 * p["layers"] * lay) + dome - 0.004 * joint_m
    r = p["roughness"] * (1 - 0.85 * p["polish"]) + 0.08 * b2 + 0.2 * joint_m
    # F0: higher where polished, lower in the joints, mottled with the colour noise (was a constant 0.04)
    # F0: one mineral surface (a polish raises it a little), the joints' mortar a little lower
    spec = (0.04 + 0.01 * p["polish"]) * (1 - 0.15 * joint_m)
    return finish(h, 1.0, col, spec[..., None], np.clip(r, 0.03, 1), albedo=PHYSICAL["diffuse"])


register_preset("stone/white_marble", "stone", {
    **rgb("color", (0.88, 0.87, 0.85), (-0.1, 0.08)), **rgb("vein", (0.35, 0.35, 0.38), (-0.2, 0.2)),
    "veins": (0.8, 0.4, 1.0), "vein_scale": (0.45, 0.2, 0.9), "turbulence": (0.8, 0.3, 1.5), "polish": (0.85, 0.5, 1.0)},
    fixed={"bump": 0.1})
register_preset("stone/granite_grey", "stone", {
    **rgb("color", (0.55, 0.53, 0.52), (-0.15, 0.15)), **rgb("vein", (0.1, 0.1, 0.1), (-0.05, 0.3)),
    "speckle": (0.8, 0.4, 1.0), "speckle_size": (0.008, 0.004, 0.02), "polish": (0.4, 0.0, 0.9),
    "roughness": (0.6, 0.4, 0.8)}, fixed={"bump": 0.2})
register_preset("stone/cobblestones", "stone", {
    **rgb("color", (0.45, 0.43, 0.4), (-0.15, 0.15)),
    "cells": (6, 4, 10), "cell_gap": (0.05, 0.02, 0.09), "cell_round": (0.7, 0.3, 1.0), "cell_var": (0.2, 0.05, 0.4),
    "bump": (0.5, 0.2, 0.9), "roughness": (0.75, 0.55, 0.95)}, fixed=rgb_fixed("joint", (0.18, 0.15, 0.12)))
register_preset("stone/slate", "stone", {
    **rgb("color", (0.22, 0.24, 0.27), (-0.08, 0.12)),
    "layers": (0.8, 0.4, 1.0), "bump": (0.5, 0.2, 0.9), "bump_scale": (0.15, 0.05, 0.3), "roughness": (0.6, 0.4, 0.85)})
register_preset("stone/sandstone", "stone", {
    **rgb("color", (0.78, 0.62, 0.42), (-0.15, 0.1)),
    "bump": (0.7, 0.4, 1.0), "bump_scale": (0.05, 0.02, 0.15), "layers": (0.4, 0.0, 0.8),
    "roughness": (0.8, 0.65, 0.95),
    "speckle": (0.2, 0.0, 0.5)}, fixed=rgb_fixed("vein", (0.6, 0.45, 0.3)))
register_preset("stone/flagstones", "stone", {
    **rgb("color", (0.5, 0.45, 0.38), (-0.15, 0.15)),
    "cells": (3, 2, 5), "cell_gap": (0.03, 0.015, 0.06), "cell_var": (0.25, 0.1, 0.5), "bump": (0.5, 0.2, 0.9),
    "bump_scale": (0.08, 0.03, 0.2), "layers": (0.3, 0.0, 0.7)}, fixed={"cell_round": 0.2})
# bush-hammered granite: the face dressed with a pointed hammer, pitted at mid scales, matte
register_preset("stone/bush_hammered", "stone", {
    **rgb("color", (0.6, 0.58, 0.56), (-0.15, 0.12)), **rgb("vein", (0.15, 0.15, 0.15), (-0.1, 0.35)),
    "bump": (0.9, 0.6, 1.0), "bump_scale": (0.04, 0.025, 0.07), "speckle": (0.6, 0.3, 0.9),
    "roughness": (0.78, 0.65, 0.92)})
