"""experiments/render_floor/probe_render_floor.py: its stopped-early integrators do what they say (the intersect
step sees the capture scene's texel under each pixel centre), and its alternative intersection renders what
``direct`` renders.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments" / "render_floor"))
import probe_render_floor as prf  # noqa: E402

RES = 64


def test_intersect_step_sees_the_pixel_centre_texel():
    # DESIGN's capture scene: film column j sees plane u in [j/res, (j+1)/res]; the centre sampler shades its
    # middle. float32 uv of a 2-unit plane carries ~1e-7 error: 1e-5 is 100x that, a tenth of a texel is 1.6e-3.
    from storage.views import planes_of, transform_planes

    from pipeline.render.views import draw_views
    import materials

    scene = prf.probe_scene(RES, "intersect")
    v = draw_views(0, 0, 1)[0]
    planes = transform_planes(planes_of(materials.presets()[0].generate(None, RES, 0)), RES, v, RES)
    img = scene.render_planes(planes, (v.light_x, v.light_y), v.seed, clip=False)
    u = (np.arange(RES) + 0.5) / RES
    assert np.abs(img[..., 0] - u[None, :]).max() < 1e-5


def test_shape_intersection_renders_what_direct_renders():
    # the same light sample and BSDF evaluation on an intersection computed by other code: differences are float32
    # rounding (observed ~1e-6 relative), bounded at 1e-4; a code flips only where a value lies within that of a
    # code threshold (observed 0-3 per million), bounded at 100 per million
    a = prf.agreement(RES, views=6, presets=3)
    assert a["views"] == 6
    assert a["max_relative_difference"] < 1e-4, a
    assert a["codes_differing_per_million"] < 100, a
