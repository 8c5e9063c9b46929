"""Helpers shared by the render tests (not fixtures: plain functions and a chi2 domain)."""
from __future__ import annotations

import math

import numpy as np

from materials.maps import SVBRDF, normalize, pack_maps
from pipeline.render import bsdf as B

mi = B.mi
import drjit as dr  # noqa: E402


class LobeDomain:
    """A chi2 parameter domain that puts fine cells around a peaked lobe.

    (phi', t) in [-pi, pi] x [0, 1] maps to the direction at polar angle theta' = pi t^p around ``center``.
    With p = 3 the first cells span ~1e-6 rad, so a GGX lobe of alpha = 0.0025 (r = 0.05) covers ~15 rows,
    which a spherical (cos theta, phi) grid of 101 rows cannot resolve (Mitsuba's own roughconductor fails there
    too). The domain is not area-preserving: pdf values must be multiplied by :meth:`jacobian`.
    theta' is computed with atan2, not acos: float32 acos near 1 is quantised to ~3e-4 rad, coarser than the lobe.
    """

    def __init__(self, center, power: float = 3.0):
        self.frame = mi.Frame3f(mi.Vector3f(center))
        self.p = power

    def bounds(self):
        return mi.ScalarBoundingBox2f([-dr.pi, 0], [dr.pi, 1])

    def aspect(self):
        return 1

    def _theta(self, w):
        loc = self.frame.to_local(w)
        return loc, dr.atan2(dr.sqrt(loc.x * loc.x + loc.y * loc.y), loc.z)

    def map_forward(self, q):
        th = dr.pi * dr.power(q.y, self.p)
        s, c = dr.sincos(th)
        sp, cp = dr.sincos(q.x)
        return self.frame.to_world(mi.Vector3f(cp * s, sp * s, c))

    def map_backward(self, w):
        loc, th = self._theta(w)
        return mi.Vector2f(dr.atan2(loc.y, loc.x), dr.power(th / dr.pi, 1.0 / self.p))

    def jacobian(self, w):
        """d(solid angle) / d(phi' t) at direction w."""
        _, th = self._theta(w)
        t = dr.power(th / dr.pi, 1.0 / self.p)
        return dr.sin(th) * dr.pi * self.p * dr.power(t, self.p - 1)


def direction(theta_deg: float, phi_deg: float = 0.0):
    """Unit vector (scalar mitsuba) at polar angle theta, azimuth phi, in degrees."""
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return mi.ScalarVector3f(float(np.sin(t) * np.cos(p)), float(np.sin(t) * np.sin(p)), float(np.cos(t)))


def checker_svbrdf(res: int, cells: int = 8, seed: int = 0) -> SVBRDF:
    """A tileable SVBRDF with sharp features: checker diffuse, bumpy normals, varying roughness/specular.

    Args:
        res: side length in texels; ``cells`` must divide it for the checker to tile.
        cells: checker squares per side.
        seed: seed of the small random normal perturbation.

    Returns:
        SVBRDF with (res, res, C) float32 maps.
    """
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:res, 0:res]
    check = ((x * cells // res + y * cells // res) % 2).astype(np.float32)[..., None]
    diffuse = 0.15 + 0.7 * check * np.array([1.0, 0.8, 0.6], np.float32)
    specular = 0.04 + 0.3 * (1 - check) * np.ones(3, np.float32)
    u = 2 * np.pi * x / res
    v = 2 * np.pi * y / res
    rough = (0.35 + 0.25 * np.sin(u)[..., None] * np.cos(v)[..., None]).astype(np.float32)
    nxy = 0.25 * np.stack([np.sin(3 * u), np.cos(2 * v)], -1) + 0.05 * rng.standard_normal((res, res, 2))
    normal = normalize(np.concatenate([nxy, np.ones((res, res, 1))], -1))
    return SVBRDF(normal=normal, diffuse=diffuse.astype(np.float32), specular=specular.astype(np.float32),
                  roughness=rough)


def _sample_coords(view, res: int, base: int, ss: int) -> tuple[np.ndarray, np.ndarray]:
    """Continuous base-texel coordinates (row, col) of the ss x ss subsamples of every output pixel.

    Returns:
        rows, cols: (res * res * ss * ss,) float64, pixel-major (the ss*ss subsamples of a pixel contiguous).
    """
    sub = (np.arange(ss) + 0.5) / ss
    pix = np.arange(res)
    # picture coordinates in picture widths, origin at the centre, x right, y up
    x = ((pix[:, None] + sub[None, :]) / res - 0.5).reshape(-1)  # (res*ss,) along columns
    y = (0.5 - (pix[:, None] + sub[None, :]) / res).reshape(-1)  # (res*ss,) along rows
    Y, X = np.meshgrid(y, x, indexing="ij")  # (res*ss, res*ss)
    c, s = math.cos(view.rotation), math.sin(view.rotation)
    # texture = zoom * R(-rotation) picture + shift: the material appears rotated by +rotation on screen
    tu = view.zoom * (c * X + s * Y) + view.shift_u
    tv = view.zoom * (-s * X + c * Y) + view.shift_v
    # texel centres at integers; identity view (zoom 1, no rotation/shift, res == base) hits texel centres
    cols = tu * base - 0.5 + base / 2
    rows = -tv * base - 0.5 + base / 2
    if ss > 1:
        rows = rows.reshape(res, ss, res, ss).transpose(0, 2, 1, 3)
        cols = cols.reshape(res, ss, res, ss).transpose(0, 2, 1, 3)
    return rows.reshape(-1), cols.reshape(-1)


def numpy_transform_maps(base: SVBRDF, view, res: int) -> SVBRDF:
    """Independent float64 numpy reference of storage.views.transform_maps. Resample tileable base maps into a view: zoom, rotation, shift with wrap-around, normals into screen space.

    Bilinear interpolation with periodic wrap; when the view minifies (more than one base texel per output
    pixel) each pixel averages ceil(texels per pixel)^2 bilinear subsamples (a box prefilter against aliasing).
    Normals are interpolated, their xy rotated by ``view.rotation`` (the gradient of a rotated height field
    rotates with it; zoom scales the surface itself, so slopes and normals do not change), and renormalised.

    Args:
        base: (B, B, C) square tileable maps.
        view: the view.
        res: output side length.

    Returns:
        SVBRDF with (res, res, C) float32 maps in screen space (numpy row 0 = image top).
    """
    b = base.normal.shape[0]
    if base.normal.shape[:2] != (b, b):
        raise ValueError(f"base maps must be square, got {base.normal.shape[:2]}")
    ss = max(1, math.ceil(view.zoom * b / res - 1e-9))
    rows, cols = _sample_coords(view, res, b, ss)
    r0 = np.floor(rows)
    c0 = np.floor(cols)
    fr = (rows - r0).astype(np.float32)[:, None]
    fc = (cols - c0).astype(np.float32)[:, None]
    r0 = r0.astype(np.int64) % b
    c0 = c0.astype(np.int64) % b
    r1 = (r0 + 1) % b
    c1 = (c0 + 1) % b
    # all 10 channels in one (B*B, 10) table: one fancy-index gather per corner instead of one per map
    table = pack_maps(base).reshape(b * b, -1)
    out = (table[r0 * b + c0] * ((1 - fr) * (1 - fc)) + table[r0 * b + c1] * ((1 - fr) * fc)
           + table[r1 * b + c0] * (fr * (1 - fc)) + table[r1 * b + c1] * (fr * fc))
    if ss > 1:
        out = out.reshape(res * res, ss * ss, -1).mean(axis=1)
    out = out.reshape(res, res, -1).astype(np.float32)

    n = out[..., 0:3]
    c, s = math.cos(view.rotation), math.sin(view.rotation)
    nx = c * n[..., 0] - s * n[..., 1]
    ny = s * n[..., 0] + c * n[..., 1]
    normal = np.stack([nx, ny, np.maximum(n[..., 2], 1e-4)], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return SVBRDF(
        normal=normal.astype(np.float32),
        diffuse=np.clip(out[..., 3:6], 0.0, 1.0),
        specular=np.clip(out[..., 6:9], 0.0, 1.0),
        roughness=np.clip(out[..., 9:10], 0.0, 1.0),
    )
