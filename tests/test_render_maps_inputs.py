"""Renders stores without maps (#42, format version 6, storage/renders_inputs.py): `svgen render` stores the images
and indices only, and readers read each SVBRDF's base maps from the input stores it records. They must be the very
codes a version-4 store (``render.maps: stored``) holds, through every reader (the reader's codes and aligned crops,
xarray, the gallery); the images are the same bytes; an input that is missing or not the rendered one is refused in
one line."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import zarr

from materials.maps import MAP_NAMES

PRESETS = ("paint/glossy_red", "wood/oak_planks", "metal/brushed_steel")
SEL = [a for p in PRESETS for a in ("--preset", p)]
RENDER = ["--config-preset", "tiny", "--views", "2", "--res", "32", "--chunk", "4", "--workers", "0"]


def _size(path) -> int:
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """Variants and a mask-mode recipe blends store, rendered together without maps (inputs) and with (stored)."""
    from pipeline.cli import cli
    from svcore.cli import run_cli

    d = tmp_path_factory.mktemp("maps_inputs")
    runs = [["sample", d / "v.zarr", "--config-preset", "tiny", "--per-preset", "2", "--workers", "0", *SEL],
            ["blend", d / "v.zarr", d / "b.zarr", "--config-preset", "tiny", "--count", "5", "--chunk", "4",
             "--mode", "mask", "--mask-per-map", "--workers", "0"]]
    for maps in ("inputs", "stored"):
        runs.append(["render", d / "v.zarr", d / "b.zarr", d / f"r_{maps}.zarr", *RENDER, "--set", f"maps={maps}"])
    for args in runs:
        assert run_cli(cli, "svgen", [str(a) for a in args]) == 0, args
    return d


def test_the_store_holds_no_maps_and_the_same_images(stores):
    from storage import local as S

    a, b = zarr.open_group(stores / "r_inputs.zarr", mode="r"), zarr.open_group(stores / "r_stored.zarr", mode="r")
    assert a.attrs["svgen"]["schema_version"] == S.SCHEMA_VERSION == 6 and b.attrs["svgen"]["schema_version"] == 4
    assert not set(MAP_NAMES) & set(a.array_keys()) and set(MAP_NAMES) <= set(b.array_keys())
    assert set(a.array_keys()) == set(b.array_keys()) - set(MAP_NAMES)
    for k in a.array_keys():  # images, views, indices: byte for byte
        assert np.array_equal(a[k][:], b[k][:]), k
    assert "base_maps" in a.attrs and "base_maps" not in b.attrs
    assert _size(stores / "r_inputs.zarr") < _size(stores / "r_stored.zarr") / 2


def test_readers_read_the_codes_a_stored_store_holds(stores):
    """Every SVBRDF (6 variants, then 5 blends mixed on read): the reader's codes, and so its decoded maps and the
    aligned crops a training read takes, equal the copy a version-4 store holds."""
    from storage.renders_store import RendersReader

    a, b = RendersReader(stores / "r_inputs.zarr"), RendersReader(stores / "r_stored.zarr")
    assert a.inputs is not None and b.inputs is None and a.n_svbrdf == b.n_svbrdf == 11 and a.base_res == 64
    for s in range(a.n_svbrdf):
        got, want = a.base_codes(s), b.base_codes(s)
        for k in MAP_NAMES:
            diff = got[k].astype(np.int64) - want[k].astype(np.int64)
            assert not diff.any(), (s, k, int(np.count_nonzero(diff)))
    for i in (0, 13, len(a) - 1):
        (ia, ma), (ib, mb) = a.crop(i, 3, 5, 16), b.crop(i, 3, 5, 16)
        assert np.array_equal(ia, ib) and all(np.array_equal(getattr(ma, k), getattr(mb, k)) for k in MAP_NAMES)


def test_the_cache_budget_holds_the_inputs_caches(stores):
    """A training loader's budget (train/loader_memory.py) covers what the input stores' caches hold."""
    from storage.renders_store import RendersReader

    r = RendersReader(stores / "r_inputs.zarr")
    r.set_cache_bytes(r.min_cache_bytes())
    for i in range(len(r)):
        r.crop(i, 0, 0, 8)
        assert r.held_bytes <= r.cache_bytes + r.plane_bytes, (i, r.held_bytes, r.cache_bytes)
    assert r.inputs.held_bytes > 0


def test_xarray_and_the_gallery_show_the_inputs_maps(stores, tmp_path):
    from pipeline.gallery import gallery
    from storage.dataset import open_dataset

    a, b = open_dataset(stores / "r_inputs.zarr"), open_dataset(stores / "r_stored.zarr")
    for k in MAP_NAMES:
        assert a[k].dims == b[k].dims and np.array_equal(a[k].values, b[k].values), k
    pages = {}
    for maps in ("inputs", "stored"):
        gallery([stores / f"r_{maps}.zarr"], tmp_path / maps)
        pages[maps] = sorted(p.relative_to(tmp_path / maps) for p in (tmp_path / maps).rglob("*.png"))
        assert pages[maps]
    assert pages["inputs"] == pages["stored"]
    for p in pages["inputs"]:  # the thumbnails of the maps read from the inputs are the copy's, byte for byte
        assert (tmp_path / "inputs" / p).read_bytes() == (tmp_path / "stored" / p).read_bytes(), p


def test_a_store_away_from_its_inputs_is_refused_in_one_line(stores, tmp_path, svgen_cli):
    moved = tmp_path / "elsewhere" / "r.zarr"
    shutil.copytree(stores / "r_inputs.zarr", moved)
    for args in (["gallery", moved, "--out", tmp_path / "g"], ["stats", moved]):
        code, err = svgen_cli(*args)
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and "Traceback" not in err, (args[0], err)
        assert "stores no maps" in lines[0] and "beside it" in lines[0], lines[0]
    assert not (tmp_path / "g").exists()
    shutil.copytree(stores / "r_stored.zarr", tmp_path / "elsewhere" / "s.zarr")  # a version-4 store travels alone
    assert svgen_cli("stats", tmp_path / "elsewhere" / "s.zarr")[0] == 0


def test_a_store_beside_other_inputs_is_refused_in_one_line(stores, tmp_path, svgen_cli):
    """Re-sampling the variants store under the recorded name (another seed) would give the images other maps."""
    shutil.copytree(stores / "r_inputs.zarr", tmp_path / "r.zarr")
    shutil.copytree(stores / "b.zarr", tmp_path / "b.zarr")
    code, err = svgen_cli("sample", tmp_path / "v.zarr", "--config-preset", "tiny", "--per-preset", "2", "--seed",
                          "1", "--workers", "0", *SEL)
    assert code == 0, err
    code, err = svgen_cli("stats", tmp_path / "r.zarr")
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert "config hash" in lines[0] and "would" in lines[0], lines[0]


def test_an_input_whose_seeds_differ_is_refused(stores, tmp_path):
    """The same config hash but other samples (a store edited in place): the recorded seeds tell."""
    from storage.renders_store import RendersReader
    from svcore.errors import StoreError

    for p in ("r_inputs.zarr", "v.zarr", "b.zarr"):
        shutil.copytree(stores / p, tmp_path / p)
    g = zarr.open_group(tmp_path / "v.zarr", mode="r+")
    seeds = g["seed"][:]
    g["seed"][:] = seeds[::-1]
    with pytest.raises(StoreError, match="seeds of .* are not the ones it rendered"):
        RendersReader(tmp_path / "r_inputs.zarr")


def test_svtrain_fits_and_evaluates_from_a_store_without_maps(stores, tmp_path):
    """Training's loader workers (forked readers) read the maps from the inputs, and so does evaluation."""
    from test_train_cli import run as svtrain

    code, _, err = svtrain("fit", "--out", tmp_path / "run", "--store", stores / "r_inputs.zarr", "--iterations", 2,
                           "--set", "model.base_width=4", "--set", "model.max_width=8", "--set", "model.levels=3",
                           "--set", "data.crop=16", "--set", "data.holdout=0.5", "--set", "optim.batch_size=2",
                           "--workers", "1", "--no-compile")
    assert code == 0, err
    code, _, err = svtrain("eval", "--checkpoint", tmp_path / "run", "--store", stores / "r_inputs.zarr", "--limit",
                           4, "--out", tmp_path / "eval")
    assert code == 0, err
    assert json.loads((tmp_path / "eval" / "eval.json").read_text())["samples"]
