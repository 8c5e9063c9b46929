"""Normal maps to DESIGN.md's convention (tangent space, x right, y up, z out, OpenGL style).

* DirectX maps store y down: green is flipped (y -> -y).
* A 2-channel map stores x, y; z = sqrt(1 - x^2 - y^2) is reconstructed. A 1-channel "normal" is refused.
* From a height map h (values as stored, 1 = ``strength`` tile widths of relief), the surface z = strength * h
  over the unit tile has the normal normalize(-dz/du, -dz/dv, 1) with u right and v up; derivatives are periodic
  central differences (tileable; second-order accurate).
* ``auto``: the file name decides when it says GL/DX; else, with a height map, the sign of the correlation
  between the map's y slopes and the height's y slopes; else OpenGL is assumed. Every choice is recorded.
"""
from __future__ import annotations

import numpy as np

from materials.capture import NORMAL_Z_MIN
from materials.maps import normalize

from . import ImportInputError

#: |correlation| below this says nothing about the convention (noise, or a height map unrelated to the normals).
MIN_AGREEMENT = 0.2


def decode(a: np.ndarray, path) -> np.ndarray:
    """Stored values (H, W, C) in [0, 1] (or signed floats from EXR) -> (H, W, 3) vectors, not yet normalised.

    Raises:
        ImportInputError: a 1-channel normal map.
    """
    c = a.shape[-1]
    if c == 1:
        raise ImportInputError(f"{path}: a normal map needs 2 or 3 channels, this one has 1 (a height or bump map "
                               "misnamed 'normal'?)")
    v = a[..., :3] * 2.0 - 1.0 if a.min() >= 0 else a[..., :3].copy()
    if c == 2:
        xy = v[..., :2]
        z = np.sqrt(np.clip(1.0 - (xy ** 2).sum(-1, keepdims=True), 0.0, 1.0))
        v = np.concatenate([xy, z], axis=-1)
    return v.astype(np.float32)


def finish(v: np.ndarray, directx: bool) -> np.ndarray:
    """Vectors -> unit normals with z > 0, green flipped for DirectX."""
    v = v.copy()
    if directx:
        v[..., 1] = -v[..., 1]
    v[..., 2] = np.maximum(v[..., 2], NORMAL_Z_MIN)  # the one normal-z floor (materials/capture.py)
    return normalize(v)


def slopes_from_height(h: np.ndarray, strength: float) -> tuple[np.ndarray, np.ndarray]:
    """Surface slopes (dz/du, dz/dv) of z = strength * h over the unit tile; h (S, S) with row 0 at the top."""
    s = h.shape[0]
    dzdu = (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) * (s / 2.0) * strength
    dzdv = (np.roll(h, 1, axis=0) - np.roll(h, -1, axis=0)) * (s / 2.0) * strength  # v up = rows decreasing
    return dzdu, dzdv


def from_height(h: np.ndarray, strength: float) -> np.ndarray:
    """(S, S) height -> (S, S, 3) unit normals."""
    du, dv = slopes_from_height(h.astype(np.float64), strength)
    return normalize(np.stack([-du, -dv, np.ones_like(du)], axis=-1).astype(np.float32))


def height_agreement(v: np.ndarray, h: np.ndarray, strength: float) -> tuple[float, float]:
    """Correlations of the normal map's x and y slopes (as stored, not flipped) with the height's.

    Returns:
        (corr_x, corr_y); an OpenGL map has both > 0, a DirectX map corr_x > 0 and corr_y < 0.
    """
    du, dv = slopes_from_height(h.astype(np.float64), strength)
    nz = np.maximum(v[..., 2], 1e-3)
    sx, sy = -v[..., 0] / nz, -v[..., 1] / nz

    def corr(a, b):
        a, b = a.ravel() - a.mean(), b.ravel() - b.mean()
        d = np.sqrt((a * a).sum() * (b * b).sum())
        return float((a * b).sum() / d) if d > 0 else 0.0

    return corr(sx, du), corr(sy, dv)
