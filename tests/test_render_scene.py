"""The capture scene: image orientation, pixel-exact map/render alignment under zoom and rotation, rotation
equivariance (normals rotated into screen space), one compiled kernel for all views, 256 and 288 renders."""
from __future__ import annotations

import gc
import math

import numpy as np
import pytest
from render_helpers import checker_svbrdf

from materials.maps import SVBRDF
from pipeline.render.scene import FlashScene
from storage.views import ViewParams, planes_of, transform_maps

import drjit as dr  # noqa: E402  (pipeline.render has configured drjit)


def _uniform(res: int, diffuse=0.5, specular=0.0, roughness=1.0) -> SVBRDF:
    n = np.zeros((res, res, 3), np.float32)
    n[..., 2] = 1
    return SVBRDF(normal=n, diffuse=np.full((res, res, 3), diffuse, np.float32),
                  specular=np.full((res, res, 3), specular, np.float32),
                  roughness=np.full((res, res, 1), roughness, np.float32))


def _diffuse_only(base: SVBRDF) -> SVBRDF:
    """Keep the diffuse map, make the rest uniform (flat, no specular): image = diffuse x smooth shading."""
    u = _uniform(base.normal.shape[0])
    return SVBRDF(normal=u.normal, diffuse=base.diffuse, specular=u.specular, roughness=u.roughness)


def test_numpy_row_0_is_the_image_top_and_column_0_the_left():
    res = 32
    m = _uniform(res, diffuse=0.1)
    m.diffuse[:8, :4] = 0.9  # a bright block in the top-left corner only
    img = FlashScene(res, 1, sampler="centre").render_maps(m, ViewParams(light_x=0.0, light_y=0.1))
    bright = img[..., 0] > 2 * np.median(img[..., 0])
    assert bright[:8, :4].all() and bright.sum() == 32


@pytest.mark.parametrize(("res", "view"), [
    (64, ViewParams(zoom=1.0, rotation=0.0, light_x=0.2, light_y=0.3)),
    (64, ViewParams(zoom=0.73, rotation=0.6, shift_u=0.3, shift_v=0.8, light_x=-0.4, light_y=0.1)),
    (64, ViewParams(zoom=1.37, rotation=2.5, shift_u=0.1, light_x=0.1, light_y=-0.5)),  # minified: 2x2 prefilter
    (96, ViewParams(zoom=1.1, rotation=4.0, shift_v=0.45, light_x=0.3, light_y=0.3)),   # res != base res
])
def test_render_lines_up_with_the_view_maps(res, view):
    """render(view maps with checker diffuse) / render(white diffuse) == the view's diffuse map, pixel for pixel.

    Texel = film pixel and nearest lookup make this exact up to float32 shading (measured < 1e-5 relative); a
    tolerance of 1e-4 is far below the 0.7 jump at every checker edge, so an offset of one pixel anywhere
    (or a flip, or a rotation in the wrong direction) fails -- the negative control below shows it.
    """
    base = _diffuse_only(checker_svbrdf(64, cells=8))
    maps = transform_maps(base, view, res)
    scene = FlashScene(res, 1, sampler="centre")
    img = scene.render_maps(maps, view, clip=False)
    white = scene.render_maps(_uniform(res, diffuse=1.0), view, clip=False)
    ratio = img / white
    np.testing.assert_allclose(ratio, maps.diffuse, rtol=0, atol=1e-4)
    edges = np.abs(np.diff(maps.diffuse[..., 0], axis=1)) > 0.3
    assert edges.sum() > res  # the feature is there: many sharp edges to misalign
    shifted = np.roll(maps.diffuse, 1, axis=1)
    assert np.abs(ratio - shifted).max() > 0.3  # negative control: one pixel off is caught


def test_rotating_light_and_material_rotates_the_image():
    """Rotating material and flash by 90 degrees about the camera axis rotates the picture by 90 degrees.

    Checks that texture rotation, the screen-space rotation of normals and the light offset share one sense of
    rotation (counter-clockwise on screen = np.rot90 with row 0 at the top). Even res: the rotation centre is a
    pixel corner, so pixel centres map onto pixel centres and the maps rotate exactly.
    """
    res = 64
    base = checker_svbrdf(64, cells=4, seed=5)
    v0 = ViewParams(zoom=0.9, rotation=0.3, light_x=0.45, light_y=0.1, seed=1)
    c, s = math.cos(math.pi / 2), math.sin(math.pi / 2)
    v1 = ViewParams(zoom=0.9, rotation=0.3 + math.pi / 2, light_x=c * 0.45 - s * 0.1, light_y=s * 0.45 + c * 0.1,
                    seed=1)
    scene = FlashScene(res, 1, sampler="centre")
    img0 = scene.render_maps(transform_maps(base, v0, res), v0, clip=False)
    img1 = scene.render_maps(transform_maps(base, v1, res), v1, clip=False)
    scale = img0.max()
    np.testing.assert_allclose(img1 / scale, np.rot90(img0) / scale, rtol=0, atol=2e-4)
    assert np.abs(img1 - img0).max() / scale > 0.1  # and the two pictures do differ


def _jit_kernels():
    return [k for k in dr.kernel_history() if k["type"] == dr.KernelType.JIT]


def _memory_hit(k) -> bool:
    """Served from drjit's in-memory kernel cache: no LLVM codegen and no load from the on-disk cache."""
    return bool(k.get("cache_hit")) and not k.get("cache_disk")


@pytest.mark.parametrize("light_model", ["point", "sphere"])
def test_views_reuse_the_compiled_kernels(light_model):
    """After one warm-up view, new textures, light positions, zooms, rotations and seeds compile nothing."""
    res = 64
    base = planes_of(checker_svbrdf(64))
    scene = FlashScene(res, 1, light_model)
    warm = ViewParams(zoom=0.8, rotation=0.1, light_x=0.3, light_y=0.2, seed=1)
    scene.render_view(base, 64, warm)
    other_base = planes_of(checker_svbrdf(64, cells=4, seed=9))
    # a kernel that dispatches over BSDFs (the sphere's MIS) traces every live BSDF instance: an earlier test's scene
    # freed by the garbage collector in the middle of the loop would change it. Free them first, and hold the collector
    gc.collect()
    gc.disable()
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    try:
        scene.render_view(base, 64, warm)
        dr.kernel_history_clear()
        per_view = []
        for k in range(4):
            v = ViewParams(zoom=0.7 + 0.05 * k, rotation=1.0 + k, shift_u=0.1 * k, light_x=-0.3 + 0.1 * k,
                           light_y=0.25, seed=100 + k)
            scene.render_view(base if k % 2 else other_base, 64, v)
            hist = _jit_kernels()
            per_view.append(len(hist))
            assert hist and all(_memory_hit(h) for h in hist), [h["hash"] for h in hist if not _memory_hit(h)]
            dr.kernel_history_clear()
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, False)
        gc.enable()
    assert len(set(per_view)) == 1  # the same kernels every view


def test_kernel_history_sees_a_recompilation():
    """Control for the test above: a new resolution is a new kernel, which the in-memory cache cannot serve
    (it is compiled, or loaded from drjit's on-disk cache if an earlier process compiled it)."""
    FlashScene(40, 1).render_maps(_uniform(40), ViewParams())
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    try:
        dr.kernel_history_clear()
        FlashScene(41, 1).render_maps(_uniform(41), ViewParams())
        assert any(not _memory_hit(h) for h in _jit_kernels())
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, False)


@pytest.mark.parametrize("res", [256, 288])
def test_paper_and_default_resolutions(res):
    base = planes_of(checker_svbrdf(256))
    img, planes = FlashScene(res, 1).render_view(base, 256, ViewParams(zoom=1.2, rotation=0.4, seed=3))
    assert img.shape == (res, res, 3) and img.dtype == np.float32
    assert np.isfinite(img).all() and 0.0 <= img.min() and img.max() <= 1.0 and img.mean() > 0.05
    assert len(planes) == 10 and all(dr.width(p) == res * res for p in planes)


def test_same_seed_same_image_other_seed_other_noise():
    base = planes_of(checker_svbrdf(64))
    scene = FlashScene(64, 1)
    v = ViewParams(seed=7)
    a, _ = scene.render_view(base, 64, v)
    b, _ = scene.render_view(base, 64, v)
    c, _ = scene.render_view(base, 64, ViewParams(seed=8))
    assert np.array_equal(a, b) and not np.array_equal(a, c)
