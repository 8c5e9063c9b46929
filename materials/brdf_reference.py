"""The reference BRDF and capture-scene render: the DESIGN.md formula per pixel, numpy float64.

The one numpy statement of the model. The drjit plugin (``pipeline/render/bsdf.py``) and the torch renderer
(``train/brdf.py``) are rewritten for speed and float32 stability and are held to this module by the tests
(``tests/test_render_reference.py``, ``test_stability.py``, ``test_agreement.py``); the catalogue's contact
sheet renders with it. Constants come from :mod:`materials.capture`.

For a point p on the plane seen through a pixel, camera c = (0, 0, D), light q = (lx, ly, D):

    v = (c - p) / |c - p|,  l = (q - p) / |q - p|,  n = the texel's normal (tangent frame = world frame)
    radiance = f(v, l) * max(n . l, 0) * I / |q - p|^2      (zero unless n.v, n.l, v_z, l_z > 0)

with f the DESIGN.md BRDF. ``subsamples = k`` averages a k x k grid of points inside each pixel (the box filter
Mitsuba integrates); k = 1 evaluates at pixel centres.
"""
from __future__ import annotations

import numpy as np

from .capture import ALPHA_MIN, CAMERA_DISTANCE, FLASH_INTENSITY, FRESNEL_SG_A, FRESNEL_SG_B
from .maps import SVBRDF


def design_brdf(n: np.ndarray, v: np.ndarray, l: np.ndarray, d: np.ndarray, s: np.ndarray,
                r: np.ndarray) -> np.ndarray:
    """The DESIGN.md BRDF f(v, l), literal form (G1 and the 1/(4 NL NV) division written out).

    Args:
        n, v, l: (..., 3) unit normal, view and light directions.
        d, s: (..., 3) diffuse albedo, specular F0.
        r: (..., 1) perceptual roughness.

    Returns:
        (..., 3) f; only meaningful where n.v > 0 and n.l > 0 (callers mask the rest).
    """
    a = np.maximum(r * r, ALPHA_MIN)
    h = v + l
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    nh = np.sum(n * h, -1, keepdims=True)
    nv = np.maximum(np.sum(n * v, -1, keepdims=True), 1e-12)
    nl = np.maximum(np.sum(n * l, -1, keepdims=True), 1e-12)
    vh = np.sum(v * h, -1, keepdims=True)
    D = a * a / (np.pi * (nh * nh * (a * a - 1) + 1) ** 2)
    k = a / 2
    G = nl / (nl * (1 - k) + k) * nv / (nv * (1 - k) + k)
    F = s + (1 - s) * 2.0 ** ((-FRESNEL_SG_A * vh - FRESNEL_SG_B) * vh)
    return d * (1 - s) / np.pi + D * F * G / (4 * nl * nv)


def render_point_flash(maps: SVBRDF, light_xy: tuple[float, float], intensity: float = FLASH_INTENSITY,
                       camera_distance: float = CAMERA_DISTANCE, subsamples: int = 1, return_spread: bool = False):
    """Per-pixel radiance of the capture scene under a point flash, unclipped.

    Args:
        maps: screen-space maps, (res, res, C), numpy row 0 = image top; texel (i, j) covers pixel (i, j).
        light_xy: flash offset in the camera plane z = camera_distance.
        intensity: point light intensity (W/sr); the capture scene's by default.
        camera_distance: D (the plane [-1, 1]^2 at z = 0 fills the picture); the capture scene's by default.
        subsamples: k: average over a k x k grid of points per pixel (1: the pixel centre).
        return_spread: also return the per-pixel standard deviation over the k x k points (the pixel-jitter
            noise of a 1-spp render).

    Returns:
        (res, res, 3) float64 radiance (and its (res, res, 3) spread when asked).
    """
    res = maps.normal.shape[0]
    n = maps.normal.astype(np.float64)
    d = maps.diffuse.astype(np.float64)
    s = maps.specular.astype(np.float64)
    r = maps.roughness.astype(np.float64)
    cam = np.array([0.0, 0.0, camera_distance])
    light = np.array([light_xy[0], light_xy[1], camera_distance])
    offs = (np.arange(subsamples) + 0.5) / subsamples
    acc = np.zeros((res, res, 3))
    acc2 = np.zeros((res, res, 3))
    j = np.arange(res)[None, :]
    i = np.arange(res)[:, None]
    for oy in offs:
        for ox in offs:
            x = np.broadcast_to(-1 + 2 * (j + ox) / res, (res, res))
            y = np.broadcast_to(1 - 2 * (i + oy) / res, (res, res))
            p = np.stack([x, y, np.zeros_like(x)], -1)
            to_cam = cam - p
            to_light = light - p
            dist2 = np.sum(to_light * to_light, -1, keepdims=True)
            v = to_cam / np.linalg.norm(to_cam, axis=-1, keepdims=True)
            l = to_light / np.sqrt(dist2)
            nl = np.sum(n * l, -1, keepdims=True)
            nv = np.sum(n * v, -1, keepdims=True)
            ok = (nl > 0) & (nv > 0) & (v[..., 2:] > 0) & (l[..., 2:] > 0)
            val = np.where(ok, design_brdf(n, v, l, d, s, r) * np.maximum(nl, 0) * intensity / dist2, 0.0)
            acc += val
            acc2 += val * val
    k2 = subsamples * subsamples
    mean = acc / k2
    if return_spread:
        return mean, np.sqrt(np.maximum(acc2 / k2 - mean * mean, 0.0))
    return mean
