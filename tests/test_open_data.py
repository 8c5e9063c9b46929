"""Stores that read themselves (issue 14): xarray opens every kind of store and decodes what svgen's own readers
read; renders stores record the held-out split that training uses; every finished store carries a dataset card
(`svgen card`); the xarray example of docs/DATA.md runs as written."""
from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
import zarr

from import_fixtures import bumpy_normals, height_field, matsynth
from test_bad_input import call

README = Path(__file__).resolve().parents[1] / "README.md"
DATA_DOC = README.parent / "docs" / "DATA.md"  # the store format, "Reading the data without svgen"
PRESETS = ("paint/glossy_red", "wood/oak_planks", "metal/brushed_steel", "plastic/glossy_blue")
#: 16-bit codes: svgen decodes in float32 (code / 65535), xarray in float64 (code * scale_factor); they differ by
#: float32 rounding, < 1e-7 on values in [0, 1].
F32 = 1e-6
#: a stored normal is (n + 1) / 2 rounded to 1/65535: each decoded component is within 1/65535 of the unit vector's,
#: so |n| is within 3e-5 of 1 and svgen's renormalisation moves a component by less than 5e-5.
NORMAL_RENORM = 5e-5


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """Every kind of store, made by the real CLI: variants, blends, stress, renders, an imported variants store and
    an imported renders store (MatSynth folders written here)."""
    from pipeline.cli import cli

    d = tmp_path_factory.mktemp("open_data")
    sel = [a for p in PRESETS for a in ("--preset", p)]
    runs = [["sample", d / "variants.zarr", "--config-preset", "tiny", "--per-preset", "1", "--chunk", "2",
             "--workers", "0", *sel],
            # blends.zarr: a stored-maps store (what plain xr.open_zarr decodes); recipe.zarr: the same blends as a
            # recipe store, the default (storage.recipe: no maps, open_dataset mixes them)
            ["blend", d / "variants.zarr", d / "blends.zarr", "--config-preset", "tiny", "--count", "3", "--chunk",
             "2", "--workers", "0", "--maps", "stored"],
            ["blend", d / "variants.zarr", d / "recipe.zarr", "--config-preset", "tiny", "--count", "3", "--chunk",
             "2", "--workers", "0"],
            ["stress", d / "stress.zarr", "--config-preset", "tiny", "--per-category", "1", "--category",
             "highlight_edge", "--category", "print_pattern", "--size", "64", "--workers", "0"],
            # renders.zarr: the default, a self-contained store with its maps (what plain xr.open_zarr decodes);
            # renders_inputs.zarr: no maps (render.maps: inputs, the paper preset's: storage/renders_inputs.py)
            ["render", d / "variants.zarr", d / "blends.zarr", d / "renders.zarr", "--config-preset", "tiny",
             "--views", "2", "--res", "16", "--chunk", "2", "--workers", "0"],
            ["render", d / "variants.zarr", d / "recipe.zarr", d / "renders_inputs.zarr", "--config-preset", "tiny",
             "--views", "2", "--res", "16", "--chunk", "2", "--workers", "0", "--set", "maps=inputs"]]
    rng = np.random.default_rng(4)
    for k in range(2):
        matsynth(d / "src", f"M{k}", 16, rng.random((16, 16, 3)), rng.random((16, 16)), height_field(16)[0])
    runs += [["import", d / "src", d / "imported.zarr", "--size", "16", "--workers", "0"]]
    for args in runs:
        code, err = call(cli, "svgen", args)
        assert code == 0, (args[0], err)
    return d


def _svbrdf_kinds():
    return ["variants", "blends", "stress", "imported"]


@pytest.mark.parametrize("name", _svbrdf_kinds())
def test_xarray_decodes_svbrdf_stores_as_svgen_reads_them(stores, name):
    from storage.store import verify_store
    from storage.svbrdf_store import SVBRDFStore

    path = stores / f"{name}.zarr"
    st = SVBRDFStore(path)
    ds = xr.open_zarr(path)
    assert ds.sizes["sample"] == len(st)
    for var in ds.data_vars.values():
        assert var.dims[0] == "sample" and var.attrs.get("long_name"), var.name
    for i in range(len(st)):
        m = st.maps(i)
        for k in ("diffuse", "specular", "roughness"):
            np.testing.assert_allclose(ds[k][i].values, getattr(m, k), rtol=0, atol=F32, err_msg=k)
        n = ds["normal"][i].values
        np.testing.assert_allclose(n, m.normal, rtol=0, atol=NORMAL_RENORM)
        np.testing.assert_allclose(n / np.linalg.norm(n, axis=-1, keepdims=True), m.normal, rtol=0, atol=F32)
        assert int(ds["seed"][i]) == st.source(i)["seed"]
    assert ds["diffuse"].attrs["units"] == "1" and "linear" in ds["diffuse"].attrs["colour_space"]
    assert verify_store(path) > 0  # metadata gained attributes; the chunk bytes still match their manifest


def test_a_recipe_store_opens_with_its_recipe_and_open_dataset_mixes_its_maps(stores):
    """A recipe blends store holds no maps: plain ``xr.open_zarr`` shows its recipe; ``open_dataset`` adds the maps,
    mixed from the variants store, equal to what it decodes from the stored-maps store of the same blends."""
    from storage.dataset import open_dataset

    plain = xr.open_zarr(stores / "recipe.zarr")
    assert {"parents", "alpha", "mask_seed", "seed"} <= set(plain.data_vars)
    assert not {"normal", "diffuse", "specular", "roughness"} & set(plain.data_vars)
    mixed, stored = open_dataset(stores / "recipe.zarr"), open_dataset(stores / "blends.zarr")
    for k in ("normal", "diffuse", "specular", "roughness"):
        assert mixed[k].dims == stored[k].dims and mixed[k].dtype == np.float32, k
        np.testing.assert_array_equal(mixed[k].values, stored[k].values, err_msg=k)
        assert mixed[k].encoding["scale_factor"] == stored[k].encoding["scale_factor"], k
        assert mixed[k].attrs == stored[k].attrs, k
    np.testing.assert_array_equal(mixed["parents"].values, stored["parents"].values)


def test_xarray_decodes_renders_as_svgen_reads_them(stores):
    import colour

    from storage.renders_store import RendersReader

    path = stores / "renders.zarr"
    r = RendersReader(path)
    ds = xr.open_zarr(path)
    assert ds.sizes["sample"] == r.n_svbrdf and ds.sizes["view_index"] == r.views
    # the image is NOT linearly encoded: no scale_factor, its transfer function named instead
    assert ds["image"].dtype == np.uint8 and "scale_factor" not in ds["image"].encoding
    assert ds["image"].attrs["transfer_function"].startswith("sRGB")
    fields = ds["view"].attrs["fields"]
    units = ds["view"].attrs["field_units"]
    assert units["rotation"] == "radian" and "world unit" in units["light_x"] and "tiles" in units["zoom"]
    for i in range(len(r)):
        s, v = divmod(i, r.views)
        # colour-science in float64 against svgen's float32 table of the same curve
        img = colour.cctf_decoding(ds["image"][s, v].values / 255.0, "sRGB")
        np.testing.assert_allclose(img, r.image(i), rtol=0, atol=F32)
        row = dict(zip(fields, ds["view"][s, v].values.tolist()))
        assert row == {k: float(x) for k, x in r.view_params(i).as_dict().items()}
    # every map of every SVBRDF, each through its own scale factor (a wrong one for any map fails here)
    maps = {k for k in ds.data_vars if "scale_factor" in ds[k].encoding}
    assert maps == {"diffuse", "normal", "specular", "roughness"}, maps
    for s in range(r.n_svbrdf):
        base = r.base_maps(s)
        for k in ("diffuse", "specular", "roughness"):
            np.testing.assert_allclose(ds[k][s].values, getattr(base, k), rtol=0, atol=F32, err_msg=f"{k} {s}")
        np.testing.assert_allclose(ds["normal"][s].values, base.normal, rtol=0, atol=NORMAL_RENORM,
                                   err_msg=f"normal {s}")


def test_imported_renders_store_opens_with_xarray(stores, tmp_path):
    """`svgen import --as renders` (the 2018 strips) writes a renders store: xarray opens it too."""
    from import_fixtures import png8
    from pipeline.cli import cli
    from storage.renders_store import RendersReader

    t, rng = 16, np.random.default_rng(5)
    tiles = [rng.random((t, t, 3)), (bumpy_normals(t, rng) + 1) / 2, rng.random((t, t, 3)),
             np.repeat(rng.random((t, t, 1)), 3, -1), rng.random((t, t, 3)) * 0.5]
    (tmp_path / "strips").mkdir()
    png8(tmp_path / "strips" / "0001;x.png", np.concatenate(tiles, 1))
    code, err = call(cli, "svgen", ["import", tmp_path / "strips", tmp_path / "r.zarr", "--layout", "deschaintre",
                                    "--as", "renders", "--size", str(t), "--workers", "0"])
    assert code == 0, err
    ds = xr.open_zarr(tmp_path / "r.zarr")
    import colour

    img = colour.cctf_decoding(ds["image"][0, 0].values / 255.0, "sRGB")
    np.testing.assert_allclose(img, RendersReader(tmp_path / "r.zarr").image(0), rtol=0, atol=F32)
    assert (tmp_path / "r.zarr" / "README.md").exists()


def test_every_array_has_dimension_names_and_the_store_metadata_only_changed(stores):
    """dimension_names and attributes live in zarr.json; chunk files are what the manifest lists."""
    for name in ("variants", "blends", "recipe", "stress", "renders", "renders_inputs", "imported"):
        g = zarr.open_group(stores / f"{name}.zarr", mode="r")
        for arr_name, arr in g.arrays():
            dims = arr.metadata.dimension_names
            assert dims is not None and len(dims) == arr.ndim and dims[0] == "sample", (name, arr_name)


# -- the held-out split -------------------------------------------------------------------------------------------
def test_the_stored_split_equals_the_computed_one(stores):
    from storage.renders_store import RendersReader
    from svcore.split import DEFAULT_HOLDOUT, DEFAULT_SEED, held_out_names
    from train.data import split_by_source

    r = RendersReader(stores / "renders.zarr")
    rec = r.stored_split()
    assert rec is not None and rec["holdout"] == DEFAULT_HOLDOUT and rec["seed"] == DEFAULT_SEED
    ids = r.source_presets()
    assert rec["test_materials"] == held_out_names(ids, DEFAULT_HOLDOUT, DEFAULT_SEED)
    stored = split_by_source(r, DEFAULT_HOLDOUT, DEFAULT_SEED)
    r.stored_split = lambda: None  # what an older store without the record gives
    computed = split_by_source(r, DEFAULT_HOLDOUT, DEFAULT_SEED)
    for a, b in zip(stored, computed):
        np.testing.assert_array_equal(a, b)
    assert rec["counts"]["test"] * r.views == len(stored[1]) and rec["counts"]["train"] * r.views == len(stored[0])


def _with_split(src: Path, dst: Path, test_materials: list[str]) -> Path:
    """A copy of a renders store whose recorded split holds out other materials (attributes only)."""
    shutil.copytree(src, dst)
    g = zarr.open_group(dst, mode="r+")
    g.attrs["split"] = {**g.attrs["split"], "test_materials": test_materials}
    zarr.consolidate_metadata(dst)
    return dst


@pytest.mark.filterwarnings("ignore:Object at")
def test_training_and_eval_read_the_stored_split(stores, tmp_path):
    """The split comes from the store, not from the code, when the holdout and seed match the record; other
    values compute it."""
    from storage.renders_store import RendersReader
    from train.data import split_by_source

    orig = RendersReader(stores / "renders.zarr").stored_split()["test_materials"]
    other = [p for p in PRESETS if p not in orig][:1]
    r = RendersReader(_with_split(stores / "renders.zarr", tmp_path / "r.zarr", other))
    _, test = split_by_source(r, 0.1, 0)
    assert {p for i in test for p in r.source_presets()[i]} == set(other)
    _, test_other_seed = split_by_source(r, 0.1, 1)  # not the recorded split: computed
    from svcore.split import held_out_names

    assert {p for i in test_other_seed for p in r.source_presets()[i]} <= \
        set(held_out_names(r.source_presets(), 0.1, 1))


# -- versions ------------------------------------------------------------------------------------------------------
def test_stores_record_the_code_digest_of_their_stage_not_the_package_version(stores):
    """Issue 40: the package version names the commit (0.1.0.devN+gHASH), so a store records the digest of the
    source its stage can run instead: the same code writes the same bytes on any checkout."""
    from svcore.versions import closure_digest, package_version

    attrs = json.loads((stores / "renders.zarr" / "zarr.json").read_text())["attributes"]
    versions = attrs["svgen"]["versions"]
    digest = closure_digest("pipeline.render.stage")
    assert versions["svgen_code_of"] == "pipeline.render.stage" and versions["svgen_code"] == digest
    assert versions["svgen"] == f"code {digest[:12]}" and attrs["source"] == f"svgen (code {digest[:12]})"
    assert package_version() not in json.dumps(attrs) and versions["mitsuba"]
    scene = json.loads((stores / "renders.zarr" / "zarr.json").read_text())["attributes"]["scene"]
    assert scene["mitsuba_variant"].startswith(("llvm_ad_", "cuda_ad_")) and "pinhole camera" in scene["description"]


# -- the dataset card ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["variants", "blends", "recipe", "stress", "renders", "renders_inputs", "imported"])
def test_every_finished_store_has_its_card(stores, name, svgen_cli):
    from storage.store import card_text

    path = stores / f"{name}.zarr"
    text = (path / "README.md").read_text()
    assert text == card_text(path)  # generated from the store's own attributes, nothing else
    front = yaml.safe_load(text.split("---\n")[1])
    assert front["license"] == "cc-by-4.0" and front["task_categories"]
    attrs = json.loads((path / "zarr.json").read_text())["attributes"]
    n = attrs["svgen"]["n"]
    views = zarr.open_group(path, mode="r")["image"].shape[1] if name.startswith("renders") else 1
    assert sum(s["num_examples"] for s in front["dataset_info"]["splits"]) <= n * views
    labels = {f"{i}_name" for i in ("preset", "category") if i in attrs["svgen"]["arrays"]}  # storage.labels
    assert {f["name"] for f in front["dataset_info"]["features"]} == set(attrs["svgen"]["arrays"]) | labels
    for section in ("## What it contains", "## How it was made", "## Intended use", "## Known limits",
                    "## Licence", "## Citation", "Deschaintre"):
        assert section in text, section
    if "seed" in attrs["config"]:
        assert f"seed: {attrs['config']['seed']}" in text  # the parameters as a params.yaml section
    if name.startswith("renders"):
        assert "## Pairing an image with its maps" in text and "ss = max(1, ceil(zoom * B / R))" in text
    code, out = svgen_cli("card", path)
    assert code == 0 and out == text


@pytest.mark.parametrize("name", ["variants", "blends", "recipe", "stress", "renders", "renders_inputs", "imported"])
def test_the_cards_params_section_is_the_stages_settings(stores, name):
    """The card prints a store's params.yaml section from the store alone (storage imports no pipeline config,
    #41): the recorded config less storage.card.NOT_SETTINGS. What remains must be exactly the settings class's
    keys that the stage recorded, so a stage that records a new non-setting key fails here until it is named."""
    from pipeline.config import STAGE_CONFIGS
    from storage.card import NOT_SETTINGS, _command, _section

    attrs = json.loads((stores / f"{name}.zarr" / "zarr.json").read_text())["attributes"]
    _, section = _command(attrs["svgen"]["kind"], attrs)
    fields = set(STAGE_CONFIGS[section].model_fields)
    assert not NOT_SETTINGS & fields  # a setting is never left out
    config = attrs["config"]
    assert _section(config) == {k: v for k, v in config.items() if k in fields}
    text = (stores / f"{name}.zarr" / "README.md").read_text()
    assert yaml.safe_dump({section: _section(config)}, sort_keys=False, width=120).rstrip() in text


def test_card_write_regenerates_it(stores, tmp_path, svgen_cli):
    from storage.store import verify_store

    path = tmp_path / "v.zarr"
    shutil.copytree(stores / "variants.zarr", path)
    want = (path / "README.md").read_text()
    (path / "README.md").unlink()
    code, out = svgen_cli("card", path, "--write")
    assert code == 0 and "README.md" in out
    assert (path / "README.md").read_text() == want
    verify_store(path)  # the card is beside the chunks, not among them


def test_a_partial_store_has_no_card(tmp_path, svgen_cli):
    """The card is written at finalize, inside the store being finished: an interrupted run leaves none."""
    env = {"SVGEN_TEST_KILL_AT": "chunk"}
    import os
    import sys

    r = subprocess.run([sys.executable, "-c", "from pipeline.cli import main; main()", "sample", str(tmp_path / "v.zarr"),
                        "--config-preset", "tiny", "--per-preset", "1", "--chunk", "1", "--workers", "0",
                        "--preset", PRESETS[0], "--preset", PRESETS[1]], env={**os.environ, **env},
                       capture_output=True, text=True)
    assert r.returncode != 0
    partial = tmp_path / "v.zarr.partial"
    assert partial.exists() and not (partial / "README.md").exists()
    code, err = svgen_cli("card", tmp_path / "v.zarr")
    assert code == 2 and err.count("\n") == 1 and "incomplete" in err, err


# -- the docs example -------------------------------------------------------------------------------------------------
def readme_example() -> str:
    """The python block after the ``xarray-example`` marker of docs/DATA.md."""
    text = DATA_DOC.read_text()
    m = re.search(r"<!-- xarray-example:.*?-->\s*```python\n(.*?)```", text, re.S)
    assert m, "docs/DATA.md lost its xarray example"
    return m.group(1)


def test_the_readme_example_runs_and_reads_what_svgen_reads(stores):
    from storage.renders_store import RendersReader

    code = readme_example()
    assert len(code.strip().splitlines()) <= 6 and '"data/renders.zarr"' in code
    ns: dict = {}
    exec(code.replace('"data/renders.zarr"', repr(str(stores / "renders.zarr"))), ns)
    r = RendersReader(stores / "renders.zarr")
    np.testing.assert_allclose(ns["image"], r.image(0), rtol=0, atol=F32)
    np.testing.assert_allclose(ns["diffuse"], r.base_maps(0).diffuse, rtol=0, atol=F32)
    assert ns["test"] == set(r.stored_split()["test_materials"])


def test_card_of_a_missing_or_foreign_store_is_one_line_exit_2(tmp_path, svgen_cli):
    g = zarr.open_group(tmp_path / "foreign.zarr", mode="w", zarr_format=3)
    g.create_array("x", shape=(2,), dtype="f4")
    zarr.consolidate_metadata(tmp_path / "foreign.zarr")
    (tmp_path / "plain").mkdir()
    for target, words in (("nothing.zarr", "no store at"), ("foreign.zarr", "not an svgen store"),
                          ("plain", "not a zarr v3 store")):
        for extra in ((), ("--write",)):
            code, err = svgen_cli("card", tmp_path / target, *extra)
            assert code == 2 and err.count("\n") == 1 and words in err and "Traceback" not in err, err
    assert not (tmp_path / "plain" / "README.md").exists() and not (tmp_path / "foreign.zarr" / "README.md").exists()


# -- history: the command that made a store (issue 25, item 4; normalised: issue 40) -------------------------------
def test_store_records_the_command_as_cf_history_and_the_card_prints_it(stores):
    """The command as parsed: the store itself as OUT, no worker count, options in the command's order, no time."""
    path = stores / "variants.zarr"
    history = json.loads((path / "zarr.json").read_text())["attributes"]["history"]
    sel = " ".join(f"--preset {p}" for p in PRESETS)
    assert history == f"svgen sample OUT --config-preset tiny --per-preset 1 {sel} --chunk 2", history
    card = (path / "README.md").read_text()
    how = card.split("## How it was made")[1].split("## Intended use")[0]
    assert history in how and "--params params.yaml" not in how.split("```")[1], how
    assert xr.open_zarr(path).attrs["history"] == history


def test_a_resume_appends_its_command_and_storage_options_are_not_recorded(tmp_path, svgen_cli):
    """A run killed after its first chunk, resumed by another command line for the same configuration (a key set
    by --set instead of its flag; other workers, a storage option): two history lines, the second without the
    worker count or the storage option and its value."""
    import os
    import sys

    out = tmp_path / "v.zarr"
    args = ["sample", str(out), "--config-preset", "tiny", "--per-preset", "1", "--chunk", "1",
            "--preset", PRESETS[0], "--preset", PRESETS[1]]
    r = subprocess.run([sys.executable, "-c", "from pipeline.cli import main; main()", *args, "--workers", "0"],
                       env={**os.environ, "SVGEN_TEST_KILL_AT": "chunk"}, capture_output=True, text=True)
    assert r.returncode != 0 and (tmp_path / "v.zarr.partial").exists()
    resume = [a if a != "--chunk" else "--set" for a in args]
    resume[resume.index("--set") + 1] = "chunk=1"
    code, err = svgen_cli(*resume, "--workers", "1", "--storage-option", "key=SECRETKEY")
    assert code == 0, err
    lines = json.loads((out / "zarr.json").read_text())["attributes"]["history"].split("\n")
    sel = f"--preset {PRESETS[0]} --preset {PRESETS[1]}"
    assert lines == [f"svgen sample OUT --config-preset tiny --per-preset 1 {sel} --chunk 1",
                     f"svgen sample OUT --config-preset tiny --set chunk=1 --per-preset 1 {sel}"], lines
    assert "SECRETKEY" not in (out / "zarr.json").read_text() + (out / "README.md").read_text()


# -- analysis-ready xarray (issue 25, item 11) ---------------------------------------------------------------------
@pytest.mark.parametrize("name", ["variants", "stress", "renders"])
def test_stores_carry_global_cf_attributes(stores, name):
    ds = xr.open_zarr(stores / f"{name}.zarr")
    assert ds.attrs["Conventions"].startswith("CF-") and ds.attrs["title"] == f"svgen {name} store"
    assert ds.attrs["license"] == "cc-by-4.0" and ds.attrs["source"].startswith("svgen (code ")
    command = {"variants": "sample", "stress": "stress", "renders": "render"}[name]
    assert ds.attrs["history"].startswith(f"svgen {command} ")  # and no time: test_same_bytes_anywhere.py


def test_open_dataset_labels_presets_and_categories(stores):
    from storage.dataset import open_dataset
    from storage.svbrdf_store import SVBRDFStore

    ds = open_dataset(stores / "variants.zarr")
    st = SVBRDFStore(stores / "variants.zarr")
    assert "preset" in ds.coords and ds["preset"].dtype.kind == "U"
    assert [str(x) for x in ds["preset"][:, 0].values] == [st.presets[i] for i in st.preset_table()[:, 0]]
    assert set(ds["preset"][:, 1].values.tolist()) == {""}  # a variant has one parent
    assert ds.sel(sample=ds["preset"][:, 0] == PRESETS[1]).sizes["sample"] == 1
    stress = open_dataset(stores / "stress.zarr")
    assert sorted(stress["category"].values.tolist()) == ["highlight_edge", "print_pattern"]


@pytest.mark.parametrize("name", ["variants", "renders"])
def test_open_dataset_maps_are_float32_with_the_cf_encoding_kept(stores, name):
    from storage.dataset import open_dataset

    ds, raw = open_dataset(stores / f"{name}.zarr"), xr.open_zarr(stores / f"{name}.zarr")
    for k in ("diffuse", "normal", "specular", "roughness"):
        assert ds[k].dtype == np.float32 and ds[k].encoding["dtype"] == np.uint16, k
        assert ds[k].encoding["scale_factor"] == raw[k].encoding["scale_factor"], k
        np.testing.assert_allclose(ds[k].values, raw[k].values, rtol=0, atol=F32, err_msg=k)


@pytest.mark.parametrize("name", ["variants", "blends", "recipe", "stress", "renders", "imported"])
def test_plain_open_zarr_gives_the_names_as_string_coordinates(stores, name):
    """Without svgen (issue 25 item 11): ``xr.open_zarr`` makes ``preset_name``/``category_name`` string
    coordinates equal to what svgen's readers resolve the stored indices to (open_dataset's labels)."""
    from storage.dataset import open_dataset

    path = stores / f"{name}.zarr"
    ds, ref = xr.open_zarr(path), open_dataset(path)
    found = [i for i in ("preset", "category") if i in ds.variables]
    assert "preset" in found and (name != "stress" or "category" in found), found
    for index in found:
        label = f"{index}_name"
        assert label in ds.coords and ds[label].dims == ds[index].dims, (label, list(ds.coords))
        values = ds[label].values
        assert values.dtype.kind in "UT" and all(type(v) is str for v in values.ravel()), values.dtype
        if ref[index].dtype.kind == "U":  # labelled by svgen from the group attribute
            assert values.tolist() == ref[index].values.tolist(), label
        else:  # no names in the store: every index is -1
            assert (ds[index].values == -1).all() and set(values.ravel().tolist()) == {""}, label
    assert label_free(ref), list(ref.variables)
    if name == "variants":
        sel = ds.sel(sample=(ds["preset_name"][:, 0] == PRESETS[1]).compute())  # a lazy coordinate, like the maps
        assert sel.sizes["sample"] == 1 and sel["diffuse"].shape[0] == 1


def label_free(ds) -> bool:
    """open_dataset labels the index arrays under their own names: no stored ``*_name`` duplicate stays."""
    return not any(v.endswith("_name") for v in ds.variables)


#: what the docs say of plain ``xr.open_zarr`` in their first paragraph about xarray (issue 40): that svgen's helper
#: is needed, and why (float64 maps, a to_netcdf that raises TypeError on the nested attributes)
PLAIN_LIMITS = ("`storage.dataset.open_dataset", "float64", "`to_netcdf`", "TypeError", "`svgen` and `config`")


def first_paragraph_on_xarray(text: str) -> str:
    """The first paragraph (blank-line separated) of ``text`` that mentions xarray, on one line."""
    return next(" ".join(p.split()) for p in text.split("\n\n") if "xarray" in p)


@pytest.mark.filterwarnings("ignore:saving variable:xarray.SerializationWarning")
@pytest.mark.parametrize("name", ["variants", "blends", "stress", "renders", "imported"])
def test_the_docs_say_first_why_plain_open_zarr_falls_short_and_it_does(stores, tmp_path, name):
    """The README (its first hour), docs/DATA.md ("Reading the data without svgen") and every store's card say, in
    their first paragraph about xarray, that ``storage.dataset.open_dataset`` is needed and why; and plain ``xr.open_zarr``
    falls short just so: 16-bit maps decode to float64 (xarray takes the decoded type from the Python type of
    ``scale_factor``, and zarr attributes are JSON, whose numbers read back as float64) and ``to_netcdf`` raises
    TypeError on the nested ``svgen``/``config`` attributes. If xarray ever does either by itself, this fails:
    update the docs (storage.card.XARRAY_NOTE, README, docs/DATA.md) and storage.dataset, which then has one thing
    less to do."""
    readme = README.read_text()
    docs = {"README, first hour": first_paragraph_on_xarray(readme),
            "docs/DATA.md, reading without svgen": first_paragraph_on_xarray(
                DATA_DOC.read_text().split("## Reading the data without svgen", 1)[1]),
            "card": first_paragraph_on_xarray((stores / f"{name}.zarr" / "README.md").read_text())}
    for where, text in docs.items():
        assert all(p in text for p in PLAIN_LIMITS), (where, [p for p in PLAIN_LIMITS if p not in text], text)
    ds = xr.open_zarr(stores / f"{name}.zarr")
    for k in ("diffuse", "normal", "specular", "roughness"):
        assert ds[k].encoding["dtype"] == np.uint16 and ds[k].dtype == np.float64, (k, ds[k].dtype)
        assert isinstance(ds[k].encoding["scale_factor"], float), k
    assert isinstance(ds.attrs["svgen"], dict) and isinstance(ds.attrs["config"], dict)
    with pytest.raises(TypeError, match="Invalid value for attr '(svgen|config)'"):
        ds.to_netcdf(tmp_path / "plain.nc", engine="h5netcdf")


def test_a_store_finished_without_name_arrays_still_opens(tmp_path, monkeypatch):
    """Stores finished before storage.labels (no ``*_name`` arrays, no ``coordinates`` attribute) read as before:
    svgen's readers, open_dataset's labels and plain xarray."""
    import storage.labels
    from pipeline.config import SampleConfig
    from pipeline.sample import run_sample
    from storage.dataset import open_dataset
    from storage.svbrdf_store import SVBRDFStore
    from svcore.config import build

    out = tmp_path / "old.zarr"
    monkeypatch.setattr(storage.labels, "write_labels", lambda *a: [])  # svgen as it was
    run_sample(out, build(SampleConfig, "tiny", presets=PRESETS[:2], per_preset=1, chunk=1), workers=0)
    assert "preset_name" not in zarr.open_group(out, mode="r")
    st = SVBRDFStore(out)
    assert sorted(st.presets[i] for i in st.preset_table()[:, 0]) == sorted(PRESETS[:2])
    assert "preset_name" not in xr.open_zarr(out).variables
    assert sorted(open_dataset(out)["preset"][:, 0].values.tolist()) == sorted(PRESETS[:2])


def test_open_dataset_chunks_by_shard(stores):
    from storage.dataset import open_dataset

    ds = open_dataset(stores / "variants.zarr")  # made with --chunk 2: two samples per shard
    assert xr.open_zarr(stores / "variants.zarr")["diffuse"].chunks[0] == (1, 1, 1, 1)
    assert ds["diffuse"].chunks[0] == (2, 2)


@pytest.mark.filterwarnings("ignore:saving variable:xarray.SerializationWarning")  # the codes hold no NaN
@pytest.mark.parametrize("name", ["variants", "blends", "recipe", "stress", "renders", "imported"])
def test_open_dataset_writes_to_netcdf_and_reads_back(stores, tmp_path, name):
    from storage.dataset import open_dataset

    ds = open_dataset(stores / f"{name}.zarr")  # the plain open's TypeError: the test above
    ds.to_netcdf(tmp_path / "x.nc", engine="h5netcdf")
    back = xr.open_dataset(tmp_path / "x.nc", engine="h5netcdf")
    assert json.loads(back.attrs["svgen"])["kind"] == json.loads(ds.attrs["svgen"])["kind"]
    assert back.attrs["history"] == ds.attrs["history"]
    np.testing.assert_allclose(back["diffuse"].values, ds["diffuse"].values, rtol=0, atol=F32)
    for c in ("preset", "category"):
        if c in ds.coords:
            assert back[c].values.tolist() == ds[c].values.tolist()


# -- the card's Hugging Face metadata (issue 25, item 12) -------------------------------------------------------------
@pytest.mark.parametrize("name", ["variants", "stress", "renders", "imported"])
def test_card_metadata_is_valid_hugging_face_dataset_card_data(stores, name):
    """huggingface_hub parses the front matter; datasets reads the features back as the arrays' shapes and
    dtypes (Value, fixed-length list, ArrayND), with nothing outside its schema."""
    from datasets import Features, Value
    from huggingface_hub import DatasetCard

    path = stores / f"{name}.zarr"
    card = DatasetCard((path / "README.md").read_text())
    assert card.data.license == "cc-by-4.0" and card.data.task_categories == ["image-to-image"]
    features = Features._from_yaml_list(card.data.dataset_info["features"])
    assert Features._from_yaml_list(features._to_yaml_list()) == features
    assert features._to_yaml_list() == card.data.dataset_info["features"]  # no key outside HF's schema
    g = zarr.open_group(path, mode="r")
    assert set(features) == set(g.array_keys())
    for k, f in features.items():
        shape, dtype = g[k].shape[1:], "string" if g[k].dtype.kind in "OTU" else str(g[k].dtype)
        if isinstance(f, Value):
            assert shape == () and f.dtype == dtype, k
        elif hasattr(f, "length"):
            assert (f.length,) == shape and f.feature.dtype == dtype, k
        else:
            assert tuple(f.shape) == shape and f.dtype == dtype, k
