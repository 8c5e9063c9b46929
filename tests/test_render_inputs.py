"""`svgen render` over several inputs (variants + blends + stress): provenance, categories, light overrides."""
from __future__ import annotations

import math

import numpy as np

from pipeline.config import BlendConfig, RenderConfig, SampleConfig, StressConfig
from pipeline.render.stage import run_render
from storage.renders_store import RendersReader
from pipeline.stress import EDGE_LIGHT_RADIUS, run_stress
from storage.svbrdf_store import SVBRDFStore
from svcore.config import build


def test_render_of_variants_blends_and_stress_keeps_provenance(tmp_path):
    from pipeline.blend import run_blend
    from pipeline.sample import run_sample

    v, b, s, r = (tmp_path / n for n in ("v.zarr", "b.zarr", "s.zarr", "r.zarr"))
    run_sample(v, build(SampleConfig, "tiny", presets=("metal/polished_gold", "wood/oak_planks"), per_preset=2), workers=0)
    run_blend(v, b, build(BlendConfig, "tiny", count=2), workers=0)
    run_stress(s, build(StressConfig, per_category=1, size=64, categories=("highlight_edge", "print_pattern")),
               workers=0)
    run_render([v, b, s], r, build(RenderConfig, "tiny", views=2), workers=0)

    rd = RendersReader(r)
    assert len(rd) == (4 + 2 + 2) * 2
    assert [i["kind"] for i in rd.attrs["inputs"]] == ["variants", "blends", "stress"]
    presets = rd.source_presets()
    assert presets[0] == ("metal/polished_gold",) and presets[6] == ("wood/oak_planks",)
    blend_src = SVBRDFStore(b).source(0)["presets"]
    assert list(presets[8]) == blend_src and rd.source(8)["input_kind"] == "blends"
    cats = rd.categories_of_views()
    assert cats[:12] == [None] * 12 and cats[12:] == ["highlight_edge"] * 2 + ["print_pattern"] * 2
    # the stress sample's views use its own light radius; the others the default annulus
    edge = [math.hypot(rd.view_params(i).light_x, rd.view_params(i).light_y) for i in (12, 13)]
    assert all(EDGE_LIGHT_RADIUS[0] <= x <= EDGE_LIGHT_RADIUS[1] for x in edge)
    assert all(math.hypot(rd.view_params(i).light_x, rd.view_params(i).light_y) <= 0.7 for i in range(12))
    # global SVBRDF index seeds the views: rendering the stress store alone draws different views for it
    alone = tmp_path / "alone.zarr"
    run_render(s, alone, build(RenderConfig, "tiny", views=2), workers=0)
    assert not np.array_equal(RendersReader(alone).image(0), rd.image(12))
