"""Several views per Mitsuba launch (``render.views_per_launch``, issues #42 and #44): the images of a launch equal
one launch per view within float rounding, in the scene and through the stage; the option is recorded where it is
used and left out at 1; the sphere flash is refused in one line.

Tolerance. A several-views launch renders the same rays as one launch per view except for the pixel position on the
wider film: the sampler's (j + 0.5) / (V res) times V rounds differently from (j + 0.5) / res, by about one float32
ulp, so the ray direction, hit point and GGX half vector move by ~1e-7 relative. An 8-bit code can only flip where
the value lies that close to a rounding boundary: /tmp measurements of 10 random views gave 0 codes of 122,880 at 64²,
12 of 1,966,080 at 256² (6 per million), each by one. The bound, every code within 1 and at most 1e-4 of them
different, is 16x the measured share; a view given another view's textures or flash (a wrong view index) changes
most codes by far more than one.
"""
from __future__ import annotations

import numpy as np
import pytest
import zarr

from pipeline.config import RenderConfig, SampleConfig
from pipeline.render.stage import launch_groups, run_render
from pipeline.sample import run_sample
from svcore.config import build

#: at most this share of 8-bit codes may differ, by one (the module docstring)
MAX_SHARE = 1e-4


def _compare(a: np.ndarray, b: np.ndarray) -> None:
    d = np.abs(a.astype(np.int16) - b.astype(np.int16))
    assert d.max() <= 1 and (d > 0).mean() <= MAX_SHARE, (int(d.max()), float((d > 0).mean()))


def test_a_launch_of_views_equals_a_launch_per_view():
    """Ten views with their own random textures and flashes, in one launch and one by one."""
    from pipeline.render.scene import FlashScene, mi

    res, n = 48, 10
    one = FlashScene(res, 1, "point", "centre")
    many = FlashScene(res, 1, "point", "centre", views=n)
    rng = np.random.default_rng(3)
    planes = []
    for _ in range(n):
        p = rng.uniform(0.1, 0.9, (10, res * res)).astype(np.float32)
        p[0:2] -= 0.5  # normal xy in [-0.4, 0.4], z in [0.1, 0.9]: tilted everywhere
        planes.append([mi.Float(c) for c in p])
    lights = [tuple(map(float, xy)) for xy in rng.uniform(-0.7, 0.7, (n, 2))]
    want = np.stack([one.render_planes_srgb8(planes[k], lights[k], k) for k in range(n)])
    got = many.render_views_srgb8(planes, lights, 0)
    assert got.shape == want.shape == (n, res, res, 3)
    assert np.ptp(want.reshape(n, -1).mean(axis=1)) > 5  # the views differ: a wrong view index would show
    _compare(got, want)


def test_a_launch_refuses_the_wrong_number_of_views():
    from pipeline.render.scene import FlashScene

    many = FlashScene(16, 1, "point", "centre", views=3)
    with pytest.raises(ValueError, match="3 views per launch"):
        many.render_views_srgb8([[]] * 2, [(0.0, 0.0)] * 2, 0)


def test_launch_groups_cover_every_view_once():
    assert launch_groups(10, 4) == [range(0, 4), range(4, 8), range(8, 10)]
    assert launch_groups(10, 1) == [range(k, k + 1) for k in range(10)]
    assert launch_groups(3, 10) == [range(0, 3)]


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    """3 variants of two presets at 64^2."""
    out = tmp_path_factory.mktemp("vpl_in") / "variants.zarr"
    run_sample(out, build(SampleConfig, "tiny", presets=("paint/glossy_red", "wood/oak_planks"), per_preset=2),
               workers=0)
    return out


def test_the_stage_renders_the_same_views_and_records_the_option(variants, tmp_path):
    """5 views per SVBRDF in launches of 3 (a launch of 3 and one of 2) against one per view: the same view
    parameters, images within rounding; the option is in the recorded config of the store that used it only."""
    cfg = build(RenderConfig, "tiny", views=5, chunk=2)
    run_render(variants, tmp_path / "one.zarr", cfg, workers=0)
    run_render(variants, tmp_path / "three.zarr", cfg.model_copy(update={"views_per_launch": 3}), workers=0)
    a, b = zarr.open_group(tmp_path / "one.zarr", mode="r"), zarr.open_group(tmp_path / "three.zarr", mode="r")
    assert "views_per_launch" not in a.attrs["config"] and b.attrs["config"]["views_per_launch"] == 3
    assert a.attrs["svgen"]["config_hash"] != b.attrs["svgen"]["config_hash"]
    np.testing.assert_array_equal(a["view"][:], b["view"][:])
    _compare(b["image"][:], a["image"][:])


def test_the_sphere_flash_is_refused_in_one_line(variants, tmp_path, svgen_cli):
    code, msg = svgen_cli("render", variants, tmp_path / "o.zarr", "--config-preset", "tiny", "--light", "sphere",
                          "--views-per-launch", "2", "--workers", "0")
    assert code != 0 and "views_per_launch 2 needs the point flash" in msg, msg
    assert len(msg.strip().splitlines()) == 1 and "Traceback" not in msg, msg
    assert not (tmp_path / "o.zarr").exists()


def test_a_worker_keeps_its_scenes_for_each_launch_size():
    """10 views in launches of 3 end with a launch of 1: the worker keeps both scenes (loading and compiling one
    again at every switch would cost more than the launches save); another render setting replaces them."""
    from pipeline.render import stage

    three = stage._scene(32, 1, "point", "centre", 3)
    one = stage._scene(32, 1, "point", "centre", 1)
    assert stage._scene(32, 1, "point", "centre", 3) is three and stage._scene(32, 1, "point", "centre", 1) is one
    stage._scene(48, 1, "point", "centre", 1)
    assert all(k[0] == 48 for k in stage._SCENES)
