"""The view distribution: how the renderer draws each view's light offset, texture transform and seed.

What a view is (:class:`~storage.views.ViewParams`, the row a renders store keeps) and the transform that gives its
aligned maps (:func:`~storage.views.transform_planes`) belong to the store, :mod:`storage.views`, which the
renderer and the store's reader both import; this module is how ``svgen render`` draws them.

View distribution (:func:`draw_view`), all independent:

* light offset (x, y) in the camera plane z = D, in world units (the plane spans [-1, 1]^2):
  radius sqrt(U(R_MIN^2, R_MAX^2)) (uniform over the annulus; ``materials.capture.LIGHT_R_MIN``, ``LIGHT_R_MAX``),
  angle U(0, 2 pi). For a flat mirror the highlight is at the midpoint (x/2, y/2) of camera and light, so
  R_MAX = 0.7 keeps its centre within 0.35 of the image centre (the middle ~35 % of the half-width).
  R_MIN = 0.1 keeps a sphere flash (radius <= 0.05) off the camera's frustum (a sphere at lateral offset rho
  blocks camera rays unless rho > ~1.5 radius).
* zoom: tiles of the base map across the picture width, log-uniform in [ZOOM_MIN, ZOOM_MAX] = [0.7, 1.4] (the
  default of ``render.zoom``, which sets another range)
  (mild magnification to mild minification; minified views are box-prefiltered by supersampling).
* rotation: U(0, 2 pi) counter-clockwise on screen.
* shift: U(0, 1)^2 tiles (so views do not all share the tile's corner at the picture centre).
* seed: a 31-bit seed for ``mi.render``.
"""
from __future__ import annotations

import math

import numpy as np

from materials.capture import LIGHT_R_MAX as R_MAX
from materials.capture import LIGHT_R_MIN as R_MIN

from svcore.seeds import rng_for

from storage.views import ViewParams

ZOOM_MIN, ZOOM_MAX = 0.7, 1.4


def draw_view(rng: np.random.Generator, light_radius: tuple[float, float] = (R_MIN, R_MAX),
              zoom_range: tuple[float, float] = (ZOOM_MIN, ZOOM_MAX)) -> ViewParams:
    """Draw one view from the distribution of the module docstring.

    Args:
        rng: the view's generator.
        light_radius: (min, max) light offset radius; the stress suite widens it to push the highlight to the
            image border.
        zoom_range: (min, max) of the log-uniform zoom (``render.zoom``); the same draws from the generator
            whatever the range, so a range changes the zoom of each view and nothing else.
    """
    r0, r1 = light_radius
    rho = math.sqrt(rng.uniform(r0**2, r1**2))
    phi = rng.uniform(0.0, 2 * math.pi)
    zoom = math.exp(rng.uniform(math.log(zoom_range[0]), math.log(zoom_range[1])))
    return ViewParams(
        light_x=rho * math.cos(phi),
        light_y=rho * math.sin(phi),
        zoom=zoom,
        rotation=rng.uniform(0.0, 2 * math.pi),
        shift_u=rng.uniform(0.0, 1.0),
        shift_v=rng.uniform(0.0, 1.0),
        seed=int(rng.integers(0, 2**31)),
    )


def draw_views(master_seed: int, sample_index: int, n_views: int,
               light_radius: tuple[float, float] = (R_MIN, R_MAX),
               zoom_range: tuple[float, float] = (ZOOM_MIN, ZOOM_MAX)) -> list[ViewParams]:
    """The views of one SVBRDF: view k is a pure function of (master seed, sample index, k) and the ranges."""
    return [draw_view(rng_for(master_seed, "render", sample_index, k), light_radius, zoom_range)
            for k in range(n_views)]
