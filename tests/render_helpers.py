"""Helpers shared by the render tests (not fixtures: plain functions and a chi2 domain)."""
from __future__ import annotations

import numpy as np

from materials.maps import SVBRDF, normalize
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
