"""The blending rule of two SVBRDFs: what `svgen blend` applies and what a recipe blends store's reader applies.

Maps mix linearly, m = w * m_a + (1 - w) * m_b, with w = alpha (scalar mode, the paper) or a tileable procedural
mask in [0, 1] whose expected mean is alpha (mask mode). Normals mix as slopes: s = (n_x, n_y) / n_z of each parent
mixed linearly, then n = normalize(s_x, s_y, 1). Mixing slopes is mixing height gradients (what blending two height
fields does) and always gives z > 0; mixing vectors would give a zero vector for opposite normals.

It lives here, numpy only, rather than in the blend stage, because a recipe blends store (#42: the parents and
weights of each blend, no maps) is mixed on read by :mod:`storage.recipe`, and storage never imports pipeline.
"""
from __future__ import annotations

import numpy as np
from scipy.special import ndtri

from .maps import MAP_NAMES, SVBRDF, normalize
from .noise import fbm

MIN_NZ = 1e-3  # slopes of normals flatter than this are clamped: keeps n/n_z finite
MASK_EDGE = 0.35  # soft edge of mask transitions, in standard deviations of the mask noise
MODES = ("scalar", "mask")


def blend_normals(na: np.ndarray, nb: np.ndarray, w: np.ndarray | float) -> np.ndarray:
    """Mix two normal maps as slopes.

    Args:
        na, nb: (H, W, 3) unit normals, z > 0.
        w: weight of ``na``: scalar or (H, W, 1).

    Returns:
        (H, W, 3) unit normals with z > 0.
    """
    wa = w[..., 0] if np.ndim(w) == 3 else w
    za, zb = np.maximum(na[..., 2], MIN_NZ), np.maximum(nb[..., 2], MIN_NZ)
    # by channel plane, not (H, W, 2) slices: numpy's inner loop would otherwise run over an axis of length 2
    v = np.empty(na.shape[:-1] + (3,), np.float32)
    for c in range(2):
        v[..., c] = wa * (na[..., c] / za) + (1.0 - wa) * (nb[..., c] / zb)
    v[..., 2] = 1.0
    return normalize(v)


def mask(size: int, seed: int, alpha: float, scale: float) -> np.ndarray:
    """A tileable mask in [0, 1] with expected mean ~alpha: thresholded periodic fBm with soft edges.

    Returns:
        (size, size, 1) float32.
    """
    if alpha <= 0.0 or alpha >= 1.0:
        return np.full((size, size, 1), alpha, np.float32)
    f = fbm(size, seed, 1.0 / scale, beta=3.0)
    f = (f - f.mean()) / max(float(f.std()), 1e-6)
    t = ndtri(1.0 - alpha)  # P(f > t) = alpha for a unit Gaussian field
    return np.clip((f - t) / MASK_EDGE + 0.5, 0.0, 1.0)[..., None].astype(np.float32)


def blend_pair(a: SVBRDF, b: SVBRDF, weights: dict[str, np.ndarray | float]) -> SVBRDF:
    """Blend two SVBRDFs with a weight (scalar or (H, W, 1)) per map."""
    out = {k: np.asarray(weights[k] * getattr(a, k) + (1.0 - weights[k]) * getattr(b, k), np.float32)
           for k in MAP_NAMES if k != "normal"}
    out["normal"] = blend_normals(a.normal, b.normal, weights["normal"])
    return SVBRDF(**out)


def blend_weights(size: int, alpha: float, mask_seeds, mode: str, mask_per_map: bool,
                  mask_scale: float) -> dict[str, np.ndarray | float]:
    """The weight of the first parent, per map, of one blend.

    Args:
        size: map side.
        alpha: the blend's alpha (scalar mode: the weight; mask mode: the masks' expected mean).
        mask_seeds: four seeds (mask mode): one per map in MAP_NAMES order, or the first for every map.
        mode: "scalar" or "mask".
        mask_per_map: mask mode: a mask per map (else the first seed's mask for all four).
        mask_scale: mask mode: features per tile of the mask noise.

    Returns:
        map name -> float (scalar mode) or (size, size, 1) float32 mask.
    """
    # a Python float: numpy then computes in the maps' float32 as the stage always has (a numpy float64 would
    # promote the products to float64, and one ulp of difference would change stored codes)
    alpha = float(alpha)
    if mode == "scalar":
        return {k: alpha for k in MAP_NAMES}
    if mode != "mask":
        raise ValueError(f"unknown blend mode {mode!r}; known: {', '.join(MODES)}")
    seeds = [int(s) for s in mask_seeds] if mask_per_map else [int(mask_seeds[0])] * len(MAP_NAMES)
    return {k: mask(size, s, alpha, mask_scale) for k, s in zip(MAP_NAMES, seeds)}
