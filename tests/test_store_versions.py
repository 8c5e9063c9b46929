"""Store format versions (#42): renders are written as version 4, or 6 without maps (``render.maps: inputs``, the paper
preset's: tests/test_render_maps_inputs.py; version 5 changed only the blends store: tests/test_blend_recipe.py); a version-3 renders
store is still read (its images agree with its own maps:
docs/DATA.md); a newer version is refused in one line; a partial version-3 render (another integrator) is not resumed
into a mix of both renders."""
from __future__ import annotations

import pytest
import zarr

from pipeline.config import RenderConfig, SampleConfig
from pipeline.render import scene as scene_module
from pipeline.render.stage import render_writer, run_render
from storage.renders_store import RendersReader
from pipeline.sample import run_sample
from storage import local as S
from storage.store import open_store
from svcore.config import build
from svcore.errors import StoreError

CFG = dict(res=16, views=1, chunk=2)


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    out = tmp_path_factory.mktemp("versions") / "variants.zarr"
    run_sample(out, build(SampleConfig, "tiny", presets=("paint/glossy_red",), per_preset=2, chunk=2), workers=0)
    return out


def _set_version(path, v: int) -> None:
    g = zarr.open_group(path, mode="r+")
    g.attrs["svgen"] = {**g.attrs["svgen"], "schema_version": v}
    zarr.consolidate_metadata(path)


def test_renders_are_version_4_or_6_without_maps_and_a_version_3_store_is_still_read(variants, tmp_path):
    new, no_maps = tmp_path / "new.zarr", tmp_path / "no_maps.zarr"
    run_render(variants, new, build(RenderConfig, "tiny", **CFG), workers=0)
    run_render(variants, no_maps, build(RenderConfig, "tiny", **CFG, maps="inputs"), workers=0)
    assert S.UNCHANGED_SCHEMA == 4 and open_store(new, "renders").attrs["svgen"]["schema_version"] == 4
    assert S.SCHEMA_VERSION == 6 and open_store(no_maps, "renders").attrs["svgen"]["schema_version"] == 6
    old = tmp_path / "v3.zarr"
    with pytest.MonkeyPatch.context() as m:  # a store as svgen wrote it before #42: Mitsuba's direct, schema 3
        m.setattr(scene_module, "integrator_name", lambda light: "direct")
        run_render(variants, old, build(RenderConfig, "tiny", **CFG), workers=0)
    _set_version(old, 3)  # version 3's layout is version 4's: only the number differs
    r = RendersReader(old)
    assert r.group.attrs["svgen"]["schema_version"] == 3
    assert r.group["image"][:].shape == RendersReader(new).group["image"][:].shape


def test_a_newer_version_is_refused_in_one_line(variants, tmp_path):
    out = tmp_path / "r.zarr"
    run_render(variants, out, build(RenderConfig, "tiny", **CFG), workers=0)
    _set_version(out, S.SCHEMA_VERSION + 1)
    with pytest.raises(StoreError) as e:
        RendersReader(out)
    assert f"schema version {S.SCHEMA_VERSION + 1}, newer than this svgen ({S.SCHEMA_VERSION})" in str(e.value)
    assert "\n" not in str(e.value)


def test_a_partial_version_3_render_is_not_resumed(variants, tmp_path):
    """A render killed under the earlier integrator left a partial store: this svgen refuses to finish it with its
    own bytes (a store of two renderers), in one line that says what to do."""
    out = tmp_path / "killed.zarr"
    cfg = build(RenderConfig, "tiny", **CFG)
    with pytest.MonkeyPatch.context() as m:
        m.setattr(scene_module, "integrator_name", lambda light: "direct")
        w, _ = render_writer(variants, out, cfg)
        with w:  # created, no chunk written: what a kill leaves
            pass
    with pytest.raises(StoreError, match="different configuration.*delete it to start over"):
        run_render(variants, out, cfg, workers=0)
