"""View sampling and the map transform: distribution bounds, determinism, identity, agreement with an
independent float64 numpy resampler, tileability, unit normals rotated with the texture."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from render_helpers import checker_svbrdf, numpy_transform_maps

from storage.views import ViewParams, transform_maps

from pipeline.render import views as V
from pipeline.render.views import draw_view, draw_views

MAPS = ("normal", "diffuse", "specular", "roughness")


def test_views_are_a_pure_function_of_seed_index_and_view():
    a = draw_views(7, 3, 10)
    assert a == draw_views(7, 3, 10)
    assert a[:4] == draw_views(7, 3, 4)  # view k does not depend on how many views are drawn
    assert a != draw_views(7, 4, 10) and a != draw_views(8, 3, 10)
    assert len({v.seed for v in a}) == 10


def test_view_distribution_keeps_the_highlight_inside():
    rng = np.random.default_rng(0)
    vs = [draw_view(rng) for _ in range(5000)]
    rho = np.hypot([v.light_x for v in vs], [v.light_y for v in vs])
    assert rho.min() >= V.R_MIN and rho.max() <= V.R_MAX
    # mirror highlight at half the offset: within 0.35 of the centre of a picture of half-width 1
    assert (rho / 2).max() <= 0.35
    # uniform over the annulus: P(rho < r) = (r^2 - Rmin^2) / (Rmax^2 - Rmin^2)
    r = 0.5
    expected = (r**2 - V.R_MIN**2) / (V.R_MAX**2 - V.R_MIN**2)
    assert abs((rho < r).mean() - expected) < 4 * math.sqrt(expected * (1 - expected) / len(vs))
    zoom = np.array([v.zoom for v in vs])
    assert zoom.min() >= V.ZOOM_MIN and zoom.max() <= V.ZOOM_MAX
    rot = np.array([v.rotation for v in vs])
    assert rot.min() >= 0 and rot.max() < 2 * math.pi


def test_view_round_trips_through_its_array():
    v = draw_view(np.random.default_rng(1))
    assert ViewParams.from_array(v.as_array()) == v


def test_identity_view_returns_the_base_maps():
    base = checker_svbrdf(64)
    out = transform_maps(base, ViewParams(), 64)
    for k in MAPS:
        np.testing.assert_allclose(getattr(out, k), getattr(base, k), atol=2e-7)


@settings(max_examples=12, deadline=None, derandomize=True)  # CI draws the same examples every run
@given(zoom=st.floats(V.ZOOM_MIN, V.ZOOM_MAX), rotation=st.floats(0, 2 * math.pi),
       su=st.floats(0, 1), sv=st.floats(0, 1), res=st.sampled_from([32, 48, 64]))
def test_drjit_transform_matches_numpy_reference(zoom, rotation, su, sv, res):
    """The drjit kernel vs an independent float64 numpy resampler (tests/render_helpers.py).

    Tolerance 1e-4: float32 texture coordinates (~1e-5 texel for 64-texel maps, times a checker step of 0.7 in
    the bilinear weight) -- measured max 2.6e-5.
    """
    base = checker_svbrdf(64)
    v = ViewParams(zoom=zoom, rotation=rotation, shift_u=su, shift_v=sv)
    a = transform_maps(base, v, res)
    b = numpy_transform_maps(base, v, res)
    for k in MAPS:
        np.testing.assert_allclose(getattr(a, k), getattr(b, k), atol=1e-4, err_msg=k)
    np.testing.assert_allclose(np.linalg.norm(a.normal, axis=-1), 1.0, atol=1e-5)
    assert (a.normal[..., 2] > 0).all()


def test_shift_by_a_whole_tile_changes_nothing():
    """Wrap-around: the base maps tile, so shifting by one tile is the same view."""
    base = checker_svbrdf(64)
    v = ViewParams(zoom=0.9, rotation=1.1, shift_u=0.25, shift_v=0.5)
    a = transform_maps(base, v, 64)
    b = transform_maps(base, ViewParams(zoom=0.9, rotation=1.1, shift_u=1.25, shift_v=-0.5), 64)
    for k in MAPS:
        np.testing.assert_allclose(getattr(a, k), getattr(b, k), atol=1e-4)


def test_normals_rotate_with_the_texture():
    """A uniform tilt towards +x in the texture points at angle `rotation` on screen after the transform."""
    base = checker_svbrdf(32)
    t = np.array([0.5, 0.0, math.sqrt(0.75)], np.float32)
    base.normal[:] = t
    for rot in (0.0, 0.5, math.pi / 2, 3.0):
        out = transform_maps(base, ViewParams(rotation=rot), 32)
        np.testing.assert_allclose(out.normal, np.broadcast_to(
            [0.5 * math.cos(rot), 0.5 * math.sin(rot), math.sqrt(0.75)], out.normal.shape), atol=1e-6)


def test_rotation_is_counter_clockwise_on_screen():
    """A feature right of the centre (on the +u axis) appears above the centre after +90 degrees."""
    res = 64
    base = checker_svbrdf(res)
    base.diffuse[:] = 0.0
    base.diffuse[res // 2 - 2:res // 2 + 2, res - 12:res - 4] = 1.0  # a bar right of the centre
    out = transform_maps(base, ViewParams(rotation=math.pi / 2), res).diffuse[..., 0]
    rows, cols = np.nonzero(out > 0.5)
    assert rows.max() < res // 2 and abs(cols.mean() - (res / 2 - 0.5)) < 1.0  # above the centre, on the axis


@pytest.mark.parametrize("zoom", [0.7, 1.4])
def test_zoom_shows_that_many_tiles(zoom):
    """zoom z: a 1-D pattern of period one tile repeats z times across the picture width."""
    res = 128
    base = checker_svbrdf(res)
    x = np.arange(res)
    base.roughness[:] = (0.5 + 0.4 * np.cos(2 * np.pi * (x + 0.5) / res))[None, :, None]
    row = transform_maps(base, ViewParams(zoom=zoom), res).roughness[res // 2, :, 0]
    spectrum = np.abs(np.fft.rfft(row - row.mean()))
    # the dominant frequency of a non-integer number of periods lies next to it
    assert abs(np.argmax(spectrum) - zoom) <= 1.0
    crossings = np.count_nonzero(np.diff(np.sign(row - 0.5)))
    assert abs(crossings - 2 * zoom) <= 1.0


def test_a_zoom_range_changes_each_views_zoom_and_nothing_else():
    """``render.zoom`` (the #22 grid's zoom factor): the zooms are log-uniform on the range (KS test), every other
    field of each view is the default range's draw, and min == max gives exactly that zoom."""
    from scipy import stats

    lo, hi = 0.5, 2.0
    wide = [draw_view(np.random.default_rng(s), zoom_range=(lo, hi)) for s in range(2000)]
    default = [draw_view(np.random.default_rng(s)) for s in range(2000)]
    u = (np.log([v.zoom for v in wide]) - math.log(lo)) / (math.log(hi) - math.log(lo))
    assert stats.kstest(u, "uniform").pvalue > 1e-3
    for a, b in zip(wide[:200], default[:200]):
        assert {k: v for k, v in a.as_dict().items() if k != "zoom"} == \
            {k: v for k, v in b.as_dict().items() if k != "zoom"}
    assert {v.zoom for v in draw_views(3, 1, 10, zoom_range=(1.25, 1.25))} == {1.25}
    assert draw_views(3, 1, 10) == draw_views(3, 1, 10, zoom_range=(V.ZOOM_MIN, V.ZOOM_MAX))


def test_the_config_default_zoom_is_the_views_default():
    from pipeline.config import RenderConfig

    assert RenderConfig.DEFAULT_ZOOM == (V.ZOOM_MIN, V.ZOOM_MAX) == tuple(RenderConfig().zoom)


def test_packed_texels_hold_the_planes_and_refuse_another_base():
    """#42: the transform reads base maps packed texel by texel (BaseTexels); packing the planes or the maps gives
    the same texels, 10 channels in the plane order then 2 zeros each, and texels of another base are refused (an
    unchecked base would gather from the wrong rows, or past the buffer). That the packed gathers give the floats
    of one gather per plane is checked end to end by scripts/same_bytes.py (experiments/packed_texels)."""
    from materials.maps import SVBRDF, normalize
    from storage.views import TEXEL_STRIDE, BaseTexels, planes_of, texels_of, transform_planes

    rng = np.random.default_rng(5)
    b = 12
    m = SVBRDF(normal=normalize(np.dstack([rng.uniform(-0.3, 0.3, (b, b, 2)), np.ones((b, b))]).astype(np.float32)),
               diffuse=rng.uniform(0, 1, (b, b, 3)).astype(np.float32),
               specular=rng.uniform(0, 1, (b, b, 3)).astype(np.float32),
               roughness=rng.uniform(0.1, 1, (b, b, 1)).astype(np.float32))
    t = texels_of(m)
    buf = np.asarray(t.buf).reshape(b * b, TEXEL_STRIDE)
    planes = np.stack([np.asarray(p) for p in planes_of(m)], axis=-1)
    assert np.array_equal(buf[:, :10], planes) and not buf[:, 10:].any()
    assert np.array_equal(np.asarray(BaseTexels.of_planes(planes_of(m), b).buf), np.asarray(t.buf))
    with pytest.raises(ValueError, match="not 13"):
        transform_planes(t, 13, ViewParams(zoom=1.7, rotation=0.4), 9)
