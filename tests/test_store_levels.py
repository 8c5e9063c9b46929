"""Per-array zstd levels (#42: codecs and levels chosen again on the measured curve of bytes against CPU).

The images and each map carry the level their own curve chose (experiments/store_levels/results/levels.json); the
stages write those levels, through zarr and through the direct shard encoder alike; and the level is not a format
change: a store written at the former level 3 everywhere decodes to the same values.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import zarr

from pipeline.config import RenderConfig, SampleConfig
from pipeline.render.stage import run_render
from pipeline.sample import run_sample
from storage import local as S
from storage import renders_store, svbrdf_store
from svcore.config import build

LEVELS_JSON = Path(__file__).resolve().parents[1] / "experiments" / "store_levels" / "results" / "levels.json"
CFG = dict(res=16, views=2, chunk=2)
MAPS = ("diffuse", "normal", "roughness", "specular")


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    out = tmp_path_factory.mktemp("levels") / "variants.zarr"
    run_sample(out, build(SampleConfig, "tiny", presets=("paint/glossy_red", "wood/oak_planks"), per_preset=2,
                          chunk=2), workers=0)
    return out


def _level(path: Path, name: str) -> int:
    meta = json.loads((path / name / "zarr.json").read_text())
    (sharding,) = meta["codecs"]
    (zstd,) = [c for c in sharding["configuration"]["codecs"] if c["name"] == "zstd"]
    return zstd["configuration"]["level"]


def test_the_levels_are_the_measured_choice():
    chosen = json.loads(LEVELS_JSON.read_text())["chosen"]
    assert {**svbrdf_store.MAP_LEVELS, "image": renders_store.IMAGE_LEVEL} == chosen


def test_stores_record_and_write_each_arrays_level(variants, tmp_path):
    out = tmp_path / "renders.zarr"
    run_render(variants, out, build(RenderConfig, "tiny", **CFG), workers=0)
    for store, names in ((variants, MAPS), (out, ("image", *MAPS))):
        for name in names:
            want = renders_store.IMAGE_LEVEL if name == "image" else svbrdf_store.MAP_LEVELS[name]
            assert _level(store, name) == want, (store.name, name)
    assert _level(out, "view") == _level(variants, "seed") == S.ZSTD_LEVEL
    # that the chunk files hold the level the metadata records: tests/test_store_fast_write.py (the direct shard
    # encoder against zarr's own write, byte for byte, with these specs)


def test_a_store_at_the_former_level_decodes_to_the_same_values(variants, tmp_path, monkeypatch):
    new, old = tmp_path / "new.zarr", tmp_path / "old.zarr"
    run_render(variants, new, build(RenderConfig, "tiny", **CFG), workers=0)
    monkeypatch.setattr(renders_store, "IMAGE_LEVEL", 3)
    monkeypatch.setattr(svbrdf_store, "MAP_LEVELS", {k: 3 for k in MAPS})
    run_render(variants, old, build(RenderConfig, "tiny", **CFG), workers=0)
    assert {_level(old, n) for n in ("image", *MAPS)} == {3}
    a, b = zarr.open_group(new, mode="r"), zarr.open_group(old, mode="r")
    for name in ("image", *MAPS):
        np.testing.assert_array_equal(a[name][:], b[name][:], err_msg=name)
