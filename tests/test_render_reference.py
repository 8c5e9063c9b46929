"""A Mitsuba render agrees with the independent numpy evaluation of DESIGN.md (materials.brdf_reference).

Dumps difference images (.npy) under pytest's tmp dir on failure, and names the path in the message.
"""
from __future__ import annotations

import numpy as np
import pytest
from render_helpers import checker_svbrdf

from materials.brdf_reference import render_point_flash
from materials.capture import CAMERA_DISTANCE, FLASH_INTENSITY
from pipeline.render.scene import FlashScene
from storage.views import ViewParams, transform_maps

VIEWS = [ViewParams(light_x=0.3, light_y=-0.2, seed=3), ViewParams(light_x=-0.5, light_y=0.45, seed=4)]


def _dump(tmp_path, name, **arrays):
    path = tmp_path / f"{name}.npz"
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize("view", VIEWS)
def test_pixel_centres_match_numpy(view, tmp_path):
    """Stratified sampler without jitter, 1 spp: Mitsuba shades exactly the pixel centres, like the reference.

    Nothing is random, so the only difference is float32 (Mitsuba) vs float64 (numpy) arithmetic, largest at
    highlight peaks where D is most sensitive to the half vector: measured 2.8e-5 and 9.7e-5 of the image
    maximum for these two views (relative RMSE 1e-5, 5e-5). Tolerance 3e-4 of the maximum (~10, unclipped); a
    5 % error in one map is 10x larger (negative control below).
    """
    res = 64
    maps = checker_svbrdf(res)
    img = FlashScene(res, 1, "point", sampler="centre").render_maps(maps, view, clip=False)
    ref = render_point_flash(maps, (view.light_x, view.light_y), FLASH_INTENSITY, CAMERA_DISTANCE, subsamples=1)
    err = np.abs(img - ref).max() / ref.max()
    if err > 3e-4:
        path = _dump(tmp_path, "centres", mitsuba=img, numpy=ref, diff=img - ref)
        pytest.fail(f"max |mitsuba - numpy| = {err:.2e} of the maximum; images in {path}")


def test_many_spp_converge_to_the_pixel_integral(tmp_path):
    """Jittered sampling (the default, 64 spp) against the numpy pixel integral (8 x 8 points per pixel).

    With a point light the only randomness is the sample position inside the pixel, so pixel p's error is a
    mean of 64 draws with the within-pixel spread sigma_p that the reference also returns: z = err / (sigma_p /
    8) must stay within +-5.5 over all 12,288 values (P(|z| > 5.5) ~ 4e-8 each, if Gaussian; the tails of
    highlight pixels are lighter than Gaussian, since values are bounded), and the relative RMSE under 1 %.
    """
    res, spp = 64, 64
    view = ViewParams(zoom=0.9, rotation=0.7, light_x=0.2, light_y=0.35, seed=11)
    maps = transform_maps(checker_svbrdf(64, seed=3), view, res)
    img = FlashScene(res, spp, "point").render_maps(maps, view, clip=False)
    ref, spread = render_point_flash(maps, (view.light_x, view.light_y), FLASH_INTENSITY, CAMERA_DISTANCE,
                                     subsamples=8, return_spread=True)
    z = (img - ref) / (spread / np.sqrt(spp) + 1e-5 * ref.max())
    rel_rmse = np.sqrt(np.mean((img - ref) ** 2) / np.mean(ref**2))
    if np.abs(z).max() > 5.5 or rel_rmse > 0.01:
        path = _dump(tmp_path, "jitter", mitsuba=img, numpy=ref, spread=spread, z=z)
        pytest.fail(f"max |z| = {np.abs(z).max():.2f}, relative RMSE {rel_rmse:.3%}; images in {path}")


def test_reference_detects_a_wrong_formula():
    """Negative control: the comparison above sees a 5 % error in the specular lobe."""
    res = 32
    view = VIEWS[0]
    maps = checker_svbrdf(res)
    img = FlashScene(res, 1, "point", sampler="centre").render_maps(maps, view, clip=False)
    wrong = maps.__class__(normal=maps.normal, diffuse=maps.diffuse, specular=maps.specular * 1.05,
                           roughness=maps.roughness)
    ref = render_point_flash(wrong, (view.light_x, view.light_y), FLASH_INTENSITY, CAMERA_DISTANCE)
    assert np.abs(img - ref).max() / ref.max() > 2e-3
