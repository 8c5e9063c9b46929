"""Recipe blends stores (#42, storage/recipe.py): `svgen blend` stores each blend's parents, weight and mask seeds,
not its maps; readers mix the maps from the variants store to the very codes a stored-maps store holds, so the
render of either is the same bytes. The store records format version 5 (other stores keep 4), and a recipe store
whose variants store is missing or another is refused in one line."""
from __future__ import annotations

import shutil

import numpy as np
import pytest
import zarr

from materials.maps import MAP_NAMES

PRESETS = ("paint/glossy_red", "wood/oak_planks", "metal/brushed_steel", "fabric/blue_denim")
SEL = [a for p in PRESETS for a in ("--preset", p)]
MODES = {"scalar": [], "mask": ["--mode", "mask", "--mask-per-map"]}


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """A variants store and, per blend mode, the same 10 blends as a stored-maps and a recipe store."""
    from pipeline.cli import cli
    from svcore.cli import run_cli

    d = tmp_path_factory.mktemp("recipe")
    runs = [["sample", d / "v.zarr", "--config-preset", "tiny", "--per-preset", "3", "--workers", "0", *SEL]]
    for mode, flags in MODES.items():
        for maps in ("stored", "recipe"):
            runs.append(["blend", d / "v.zarr", d / f"{mode}_{maps}.zarr", "--config-preset", "tiny", "--count",
                         "10", "--chunk", "4", "--maps", maps, "--workers", "0", *flags])
    for args in runs:
        assert run_cli(cli, "svgen", [str(a) for a in args]) == 0, args
    return d


@pytest.mark.parametrize("mode", list(MODES))
def test_a_recipe_store_mixes_the_codes_a_stored_store_holds(stores, mode):
    from storage.svbrdf_store import SVBRDFStore

    stored, recipe = SVBRDFStore(stores / f"{mode}_stored.zarr"), SVBRDFStore(stores / f"{mode}_recipe.zarr")
    assert recipe.recipe is not None and stored.recipe is None and len(recipe) == len(stored) == 10
    want, got = stored.codes_range(0, 10), recipe.codes_range(0, 10)
    for k in MAP_NAMES:
        diff = got[k].astype(np.int64) - want[k].astype(np.int64)
        assert not diff.any(), (k, int(np.count_nonzero(diff)), int(np.abs(diff).max()))
    for i in (0, 7):  # one sample at a time (the cache path) as well as a range
        assert all(np.array_equal(recipe.codes(i)[k], want[k][i]) for k in MAP_NAMES), i
    assert np.array_equal(recipe.group["parents"][:], stored.group["parents"][:])


def test_renders_of_a_recipe_store_are_the_stored_stores_bytes(stores, tmp_path, svgen_cli):
    """The render reads a recipe store's maps mixed (storage.svbrdf_store.SVBRDFInputs): every array of the renders
    store, images and maps, equals the render of the stored-maps store, byte for byte."""
    out = {}
    for maps in ("stored", "recipe"):
        out[maps] = tmp_path / f"r_{maps}.zarr"
        code, err = svgen_cli("render", stores / "v.zarr", stores / f"mask_{maps}.zarr", out[maps], "--config-preset",
                              "tiny", "--views", "2", "--res", "16", "--chunk", "8", "--workers", "0")
        assert code == 0, err
    a, b = zarr.open_group(out["stored"], mode="r"), zarr.open_group(out["recipe"], mode="r")
    assert sorted(a.array_keys()) == sorted(b.array_keys())
    for k in a.array_keys():
        assert np.array_equal(a[k][:], b[k][:]), k


def test_a_recipe_store_is_version_5_with_no_maps_and_a_stored_one_is_version_4(stores):
    from storage import local as S
    from storage.store import open_store

    recipe, stored = open_store(stores / "scalar_recipe.zarr", "blends"), open_store(stores / "scalar_stored.zarr",
                                                                                       "blends")
    assert recipe.attrs["svgen"]["schema_version"] == S.RECIPE_SCHEMA == 5
    assert stored.attrs["svgen"]["schema_version"] == S.UNCHANGED_SCHEMA == 4  # what an older svgen reads
    assert not set(MAP_NAMES) & set(recipe.array_keys()) and set(MAP_NAMES) <= set(stored.array_keys())
    assert recipe["alpha"].dtype == np.float64 and recipe["mask_seed"].shape == (10, 4)
    size = {p: sum(f.stat().st_size for f in (stores / p).rglob("*") if f.is_file())
            for p in ("scalar_recipe.zarr", "scalar_stored.zarr")}
    assert size["scalar_recipe.zarr"] * 5 < size["scalar_stored.zarr"], size


def test_a_recipe_store_away_from_its_variants_is_refused_in_one_line(stores, tmp_path, svgen_cli):
    moved = tmp_path / "elsewhere" / "b.zarr"
    shutil.copytree(stores / "scalar_recipe.zarr", moved)
    for args in (["render", stores / "v.zarr", moved, tmp_path / "r.zarr", "--config-preset", "tiny", "--workers",
                  "0"], ["gallery", moved, "--out", tmp_path / "g"], ["stats", moved]):
        code, err = svgen_cli(*args)
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and "Traceback" not in err, (args[0], err)
        assert "recipe blends store" in lines[0] and "side by side" in lines[0], lines[0]
    assert not (tmp_path / "r.zarr").exists() and not (tmp_path / "g").exists()


def test_a_recipe_store_beside_another_variants_store_is_refused_in_one_line(stores, tmp_path, svgen_cli):
    """Re-sampling the variants store (another seed) under the recorded name would mix other materials."""
    shutil.copytree(stores / "scalar_recipe.zarr", tmp_path / "b.zarr")
    code, err = svgen_cli("sample", tmp_path / "v.zarr", "--config-preset", "tiny", "--per-preset", "3", "--seed",
                          "1", "--workers", "0", *SEL)
    assert code == 0, err
    code, err = svgen_cli("stats", tmp_path / "b.zarr")
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "config hash" in lines[0] and "Re-run svgen blend" in lines[0], err
