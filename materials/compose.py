"""Small building blocks shared by the material classes: parameter shorthands and map assembly."""
from __future__ import annotations

import numpy as np

from .maps import SVBRDF
from .noise import F32, height_slopes, height_to_normal
from .params import Param


def P(name: str, default: float, low: float, high: float, doc: str, kind: str = "float") -> Param:
    """Shorthand for :class:`Param`."""
    return Param(name, float(default), float(low), float(high), doc, kind)


def rgb_params(prefix: str, rgb: tuple[float, float, float], doc: str) -> list[Param]:
    """Three sRGB channel parameters ``<prefix>_r/_g/_b`` in [0, 1] (decoded with colour-science)."""
    return [Param(f"{prefix}_{c}", float(v), 0.0, 1.0, f"{doc} ({c.upper()}, sRGB)", "srgb")
            for c, v in zip("rgb", rgb)]


def rgb(prefix: str, rgb_: tuple[float, float, float], r=(0.0, 1.0)) -> dict[str, tuple]:
    """Preset ``exposed`` entries for an sRGB colour: ``{prefix_r: (r, lo, hi), ...}``, range clipped to [0, 1]."""
    return {f"{prefix}_{c}": (v, max(0.0, min(v, v + r[0])), min(1.0, max(v, v + r[1])))
            for c, v in zip("rgb", rgb_)}


def rgb_fixed(prefix: str, rgb_: tuple[float, float, float]) -> dict[str, float]:
    """Preset ``fixed`` entries for an sRGB colour."""
    return {f"{prefix}_{c}": float(v) for c, v in zip("rgb", rgb_)}


def lerp(a, b, t):
    """Linear blend; ``t`` (H, W) broadcasts over the channel axis of (H, W, 3) maps or (3,) colours."""
    t = np.asarray(t, F32)
    a, b = np.asarray(a, F32), np.asarray(b, F32)
    if t.ndim == 2 and {a.ndim, b.ndim} <= {1, 3} and a.shape[-1] == b.shape[-1]:
        # channel by channel: broadcasting t[..., None] runs numpy's inner loop over the axis of length 3
        s = 1 - t
        out = np.empty(t.shape + a.shape[-1:], F32)
        for c in range(a.shape[-1]):
            np.add(a[..., c] * s, b[..., c] * t, out=out[..., c])
        return out
    if t.ndim == 2:
        t = t[..., None]
    return (a * (1 - t) + b * t).astype(F32)


def tint(color: np.ndarray, field: np.ndarray, amount: float) -> np.ndarray:
    """Colour (3,) or (H, W, 3) modulated by a zero-mean field (H, W): ``color * exp(amount * field)`` -> (H, W, 3)."""
    c = np.asarray(color, F32)
    e = np.exp(F32(amount) * field)
    out = np.empty(e.shape + c.shape[-1:], F32)
    for i in range(c.shape[-1]):  # by channel, as in lerp
        out[..., i] = c[..., i] * e
    return out


def slope_scaled(h: np.ndarray, slope_rms: float) -> np.ndarray:
    """Height field ``h`` (H, W) rescaled so that its RMS slope (finite differences, as the normals see it) is
    ``slope_rms``: relief layers are specified by how much they tilt the surface, whatever their feature size."""
    sx, sy = height_slopes(h)
    rms = float(np.sqrt(np.mean(sx.astype(np.float64) ** 2 + sy.astype(np.float64) ** 2)))
    return (h * F32(slope_rms / max(rms, 1e-12))).astype(F32)


def finish(height: np.ndarray, strength: float, diffuse, specular, roughness,
           albedo: tuple[float, float] | None = None) -> SVBRDF:
    """Assemble an :class:`SVBRDF`, broadcasting and clipping every map to [0, 1].

    Args:
        height: (H, W) height in texture widths (see :func:`materials.noise.height_to_normal`).
        strength: slope multiplier.
        diffuse, specular: (H, W, 3), (3,) or scalars, linear.
        roughness: (H, W) or scalar.
        albedo: a dielectric class's physical diffuse range (lo, hi): the [0, 1] diffuse is mapped affinely onto
            it, so that no colour parameter, dirt or crease darkening gives an albedo no real material has
            (a class's ``PHYSICAL["diffuse"]``).
    """
    if albedo is not None:
        lo, hi = albedo
        diffuse = F32(lo) + F32(hi - lo) * np.clip(np.asarray(diffuse, F32), 0, 1)
    n = height.shape[0]
    shp3 = (n, n, 3)

    def as3(x):
        x = np.asarray(x, F32)
        if x.ndim == 2:
            x = x[..., None]
        return np.clip(np.broadcast_to(x, shp3), 0, 1).astype(F32)

    r = np.asarray(roughness, F32)
    r = np.clip(np.broadcast_to(r.reshape(r.shape + (1,)) if r.ndim == 2 else r, (n, n, 1)), 0, 1).astype(F32)
    return SVBRDF(height_to_normal(height, strength), as3(diffuse), as3(specular), r)
