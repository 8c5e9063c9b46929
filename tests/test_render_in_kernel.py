"""The view's transform inside the render kernel (``FlashScene(in_kernel=True)``, ``svgen_ggx_view``: the render
stage's path at one view per launch) against the two kernels it replaces (``transform_planes``, then the planes).

Tolerance: none. The BSDF runs :func:`storage.views.view_texel`, the function ``transform_planes`` runs, on the pixel
the nearest lookup finds, so the floats and the 8-bit codes must be equal. Seen failing:
- with the subsample count fixed at 1 (the minifying views failed);
- with the pixel's row and column swapped (every view failed).
On failure the two images are written as PNGs.
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
from render_helpers import checker_svbrdf

from pipeline.render.scene import FlashScene
from storage.views import ViewParams, texels_of, transform_planes

VIEWS = {"magnifying": ViewParams(light_x=0.3, light_y=-0.2, zoom=0.8, rotation=0.7, shift_u=0.2, seed=5),
         "minifying": ViewParams(light_x=-0.6, light_y=0.2, zoom=1.3, rotation=2.0, shift_v=0.4, seed=9),
         "strongly_minifying": ViewParams(light_x=0.1, light_y=0.5, zoom=1.4, rotation=4.1, seed=77)}


def _dump(tag: str, **images) -> str:
    from PIL import Image

    d = Path(tempfile.mkdtemp(prefix=f"svgen-in-kernel-{tag}-"))
    for name, a in images.items():
        Image.fromarray(np.asarray(a, np.uint8)).save(d / f"{name}.png")
    return str(d)


@pytest.mark.parametrize("light,sampler", [("point", "centre"), ("point", "independent"), ("sphere", "centre")])
@pytest.mark.parametrize("kind", list(VIEWS))
def test_in_kernel_gives_the_planes_codes(kind, light, sampler):
    res = 40
    base = 2 * res if kind == "strongly_minifying" else 48  # 2.8 texels a pixel: 3 x 3 subsamples
    texels = texels_of(checker_svbrdf(base, seed=3))
    view = VIEWS[kind]
    planes_scene = FlashScene(res, 1, light, sampler)
    fused = FlashScene(res, 1, light, sampler, in_kernel=True)
    want = planes_scene.render_planes_srgb8(transform_planes(texels, base, view, res), (view.light_x, view.light_y),
                                            view.seed)
    got = fused.render_view_srgb8(texels, view)
    assert want.std() > 5  # a lit checker: there is something to compare
    if not np.array_equal(got, want):
        n = int((got != want).sum())
        raise AssertionError(f"{kind}/{light}/{sampler}: {n} of {got.size} codes differ; images: "
                             f"{_dump(kind, planes=want, in_kernel=got)}")
    # and the radiance floats before the encoding
    np.testing.assert_array_equal(np.asarray(fused.radiance(view.seed)), np.asarray(planes_scene.radiance(view.seed)))


def test_the_kinds_of_scene_refuse_each_others_calls():
    texels = texels_of(checker_svbrdf(16, seed=1))
    fused = FlashScene(16, 1, "point", "centre", in_kernel=True)
    with pytest.raises(ValueError, match="in_kernel scene renders views"):
        fused.render_planes_srgb8(transform_planes(texels, 16, VIEWS["magnifying"], 16), (0.1, 0.1), 1)
    with pytest.raises(ValueError, match="needs a FlashScene\\(in_kernel=True\\)"):
        FlashScene(16, 1, "point", "centre").render_view_srgb8(texels, VIEWS["magnifying"])
    with pytest.raises(ValueError, match="one view per launch"):
        FlashScene(16, 1, "point", "centre", views=2, in_kernel=True)
    with pytest.raises(ValueError, match="a view set on it first"):
        FlashScene(16, 1, "point", "centre", in_kernel=True).radiance(1)


def test_a_planes_scene_renders_beside_an_in_kernel_one():
    """drjit traces every live BSDF into a render kernel's dispatch: an in_kernel scene without a view must not break
    another scene's render, nor change its codes."""
    texels = texels_of(checker_svbrdf(16, seed=2))
    view = VIEWS["minifying"]
    alone = FlashScene(16, 1, "point", "centre")
    want = alone.render_planes_srgb8(transform_planes(texels, 16, view, 16), (view.light_x, view.light_y), view.seed)
    fused = FlashScene(16, 1, "point", "centre", in_kernel=True)  # alive, no view set yet
    got = alone.render_planes_srgb8(transform_planes(texels, 16, view, 16), (view.light_x, view.light_y), view.seed)
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(fused.render_view_srgb8(texels, view), want)
