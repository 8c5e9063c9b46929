"""The point flash's integrator (``svgen_plane_flash``: the plane's own intersection, no shadow ray) against
Mitsuba's ``direct`` on the same scene, textures, light and samples."""
from __future__ import annotations

import numpy as np
import pytest
from render_helpers import checker_svbrdf

from pipeline.render.scene import FlashScene, scene_dict
from storage.views import ViewParams, transform_maps

#: relative tolerance, with an absolute floor of 1e-3 of the radiance. The two integrators shade the same hit with the
#: same BSDF, light and sampler; only the hit point's float32 rounding differs (Embree's ray-triangle code vs the
#: rectangle's ray-plane code: ~1e-7 of the plane's size), which moves the GGX half vector by as much. Over 45 library
#: views ``experiments/render_floor/probe_render_floor.py`` measured a max relative difference of 1.1e-5 (256²) and
#: 1.4e-5 (288²); 1e-4 leaves 7x room, yet a wrong cosine, a missing light fall-off, a shadow term or a single pixel of
#: misalignment all differ by > 1e-2.
RTOL = 1e-4


def _direct_scene(res: int) -> FlashScene:
    """The same capture scene rendered by Mitsuba's ``direct`` (1 emitter sample, no BSDF sample)."""
    from pipeline.render.scene import mi

    s = FlashScene(res, 1, "point", "centre")
    d = scene_dict(res, 1, "point", "centre")
    d["integrator"] = {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0}
    s.scene = mi.load_dict(d)
    s.params = mi.traverse(s.scene)
    return s


@pytest.mark.parametrize("view", [
    ViewParams(light_x=0.3, light_y=-0.2, zoom=1.0, rotation=0.7, seed=5),
    ViewParams(light_x=-0.65, light_y=0.2, zoom=0.8, rotation=2.0, shift_u=0.4, seed=9),  # grazing-ish, off centre
])
def test_plane_flash_matches_direct(view):
    res = 48
    base = checker_svbrdf(48, seed=4)
    maps = transform_maps(base, view, res)
    ours = FlashScene(res, 1, "point", "centre")
    assert "PlaneFlash" in str(ours.scene.integrator())
    a = ours.render_maps(maps, view, clip=False)
    b = _direct_scene(res).render_maps(maps, view, clip=False)
    assert b.max() > 0.1 and (b > 0).mean() > 0.99  # the scene is lit: the comparison has something to compare
    rel = np.abs(a - b) / np.maximum(np.abs(b), 1e-3)
    assert rel.max() < RTOL, rel.max()


def test_the_sphere_flash_keeps_direct():
    """A sphere flash needs BSDF samples that find the sphere (MIS): it stays with ``direct``."""
    assert "Direct" in str(FlashScene(16, 1, "sphere").scene.integrator())
