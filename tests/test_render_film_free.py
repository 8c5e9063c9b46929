"""The film-free render (:meth:`pipeline.render.scene.FlashScene.radiance` at one sample per pixel) against
``mi.render`` through the scene's film, on the same textures, flash and sampler seed.

Tolerance: none, the floats must be equal. Both paths run the same drjit operations on the same samples: the
pixel's position sample, its film coordinate, the sensor's ray, the integrator's ``sample``, the ray weight (1 for a
pinhole). The film then only adds the value to a zeroed pixel and divides by a weight of exactly 1. A position
sample replaced by the pixel centre (seen failing with the random samplers) or the channels in another order (seen
failing everywhere) changes most pixels by far more than one ulp. On failure the two images and their difference are
written as PNGs.
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
from render_helpers import checker_svbrdf

from pipeline.render.scene import FlashScene
from storage.views import ViewParams, transform_maps

VIEWS = [ViewParams(light_x=0.3, light_y=-0.2, zoom=1.0, rotation=0.7, seed=5),
         ViewParams(light_x=-0.65, light_y=0.2, zoom=1.3, rotation=2.0, shift_u=0.4, seed=9),
         ViewParams(light_x=0.05, light_y=0.12, zoom=0.8, rotation=4.1, shift_v=0.7, seed=123456)]


def _dump(tag: str, film: np.ndarray, free: np.ndarray) -> str:
    from PIL import Image

    d = Path(tempfile.mkdtemp(prefix=f"svgen-film-free-{tag}-"))
    diff = np.abs(film - free)
    for name, a in (("film", film), ("film_free", free), ("diff_x1000", diff * 1000)):
        Image.fromarray((np.clip(a, 0, 1) * 255).astype(np.uint8)).save(d / f"{name}.png")
    return str(d)


@pytest.mark.parametrize("light,sampler", [("point", "centre"), ("point", "independent"), ("point", "stratified"),
                                           ("sphere", "centre")])
def test_film_free_equals_the_film(light, sampler):
    res = 40
    base = checker_svbrdf(48, seed=4)
    scene = FlashScene(res, 1, light, sampler)
    for k, view in enumerate(VIEWS):
        maps = transform_maps(base, view, res)
        free = scene.render_maps(maps, view, clip=False)  # the film-free path (spp 1, one view per launch)
        film = np.asarray(scene.render_film(view.seed), np.float32).reshape(res, res, 3)
        assert free.max() > 0.1 and (free > 0).mean() > 0.9  # lit: there is something to compare
        if not np.array_equal(free, film):
            n, worst = int((free != film).sum()), float(np.abs(free - film).max())
            raise AssertionError(f"{light}/{sampler} view {k}: {n} of {free.size} values differ (max {worst:.3g}); "
                                 f"images: {_dump(f'{light}-{sampler}', film, free)}")


def test_the_stage_encoding_is_the_films():
    """The stage's 8-bit path (:meth:`FlashScene.render_planes_srgb8`) encodes the film's image."""
    from storage.srgb8 import encode_srgb8
    from storage.views import planes_of

    res = 32
    scene = FlashScene(res, 1, "point", "centre")
    view = VIEWS[1]
    planes = planes_of(transform_maps(checker_svbrdf(32, seed=7), view, res))
    codes = scene.render_planes_srgb8(planes, (view.light_x, view.light_y), view.seed)
    film = np.clip(np.asarray(scene.render_film(view.seed), np.float32).reshape(res, res, 3), 0.0, 1.0)
    np.testing.assert_array_equal(codes, encode_srgb8(film))


def test_several_samples_go_through_the_film():
    """spp > 1 averages on the film: :meth:`FlashScene.radiance` renders those with ``mi.render``."""
    scene = FlashScene(16, 4, "point", "stratified")
    maps = transform_maps(checker_svbrdf(16, seed=1), VIEWS[0], 16)
    img = scene.render_maps(maps, VIEWS[0], clip=False)
    film = np.asarray(scene.render_film(VIEWS[0].seed), np.float32).reshape(16, 16, 3)
    np.testing.assert_array_equal(img, film)
