"""`svgen export STORE OUT --format parquet`: renders and variants stores as parquet shards with `datasets` image
columns and a dataset card, read back with pyarrow and with `datasets` (a dev dependency); the PNG encoder."""
from __future__ import annotations

import io

import numpy as np
import pytest

from pipeline.config import SampleConfig
from pipeline.export import FORMATS, export, is_export
from pipeline.importer.readers import Blob, read_raw
from svcore.config import build
from svcore.image_io import png_bytes

MAPS = ("normal", "diffuse", "specular", "roughness")


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """A tiny variants store (2 presets x 2 variants) and its renders (2 views each: the store records a split)."""
    from pipeline.render.stage import RenderConfig, run_render
    from pipeline.sample import run_sample

    d = tmp_path_factory.mktemp("stores")
    run_sample(d / "v.zarr", build(SampleConfig, "tiny", presets=("paint/glossy_red", "wood/oak_planks"),
                                   per_preset=2), workers=0)
    run_render(d / "v.zarr", d / "r.zarr", build(RenderConfig, "tiny", views=2), workers=0)
    return d


def table(out):
    import pyarrow.parquet as pq

    files = sorted((out / "data").glob("*.parquet"))
    return files, {f.name: pq.read_table(f) for f in files}


@pytest.mark.parametrize("shape, dtype", [((5, 7), np.uint8), ((5, 7, 3), np.uint8), ((6, 4, 4), np.uint8),
                                          ((5, 7), np.uint16), ((5, 7, 3), np.uint16), ((3, 9, 2), np.uint16)])
def test_png_bytes_round_trip(shape, dtype, rng):
    """The encoder's PNGs decode to the codes given: with pypng (any depth), and with Pillow where Pillow keeps
    them (8-bit, 16-bit grey)."""
    import png
    from PIL import Image

    a = rng.integers(0, np.iinfo(dtype).max + 1, shape, dtype=dtype)
    b = png_bytes(a)
    w, h, rows, meta = png.Reader(bytes=b).asDirect()
    np.testing.assert_array_equal(np.vstack([np.asarray(r) for r in rows]).reshape(a.shape), a)
    if dtype == np.uint8 or a.ndim == 2:
        np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(b))), a)
    assert png_bytes(a) == b  # a function of the codes


def test_variants_export_is_lossless_and_loads_with_datasets(stores, tmp_path):
    """Every sample of a variants store: its stored codes, exactly, as 16-bit PNGs; `datasets` reads the folder
    through its card (configs, features) with Image columns."""
    import datasets
    from huggingface_hub import DatasetCard

    from storage.svbrdf_store import SVBRDFStore

    st = SVBRDFStore(stores / "v.zarr")
    out = tmp_path / "v_pq"
    assert export(stores / "v.zarr", out, "parquet") == len(st) == 4
    files, tables = table(out)
    assert [f.name for f in files] == ["train-00000-of-00001.parquet"]
    t = tables[files[0].name]
    assert t.num_rows == 4 and t.column_names == [*MAPS, "material", "seed"]
    for i, row in enumerate(t.to_pylist()):
        for k in MAPS:
            got = read_raw(Blob(k, row[k]["bytes"]))
            np.testing.assert_array_equal(got, st.codes(i)[k], err_msg=f"sample {i} {k}")
            assert got.dtype == np.uint16
        assert row["material"] == st.source(i)["presets"][0] and row["seed"] == st.source(i)["seed"]
    card = DatasetCard.load(out / "README.md")
    assert card.data.license == "cc-by-4.0"
    assert card.data.configs == [{"config_name": "default", "data_files": [{"split": "train",
                                                                            "path": "data/train-*"}]}]
    # without the card, the schema's `datasets` features make Image columns
    plain = datasets.load_dataset("parquet", data_files={"train": str(files[0])})
    assert all(isinstance(plain["train"].features[k], datasets.Image) for k in MAPS)
    ds = datasets.load_dataset(str(out))  # through the card's configs/data_files and features
    assert list(ds) == ["train"] and ds["train"].num_rows == 4
    assert all(isinstance(ds["train"].features[k], datasets.Image) for k in MAPS)
    assert datasets.Features._from_yaml_list(card.data.dataset_info["features"]) == ds["train"].features
    raw = ds["train"].cast_column("diffuse", datasets.Image(decode=False))[1]["diffuse"]["bytes"]
    np.testing.assert_array_equal(read_raw(Blob("d", raw)), st.codes(1)["diffuse"])
    # Pillow keeps a 16-bit grey PNG's 16 bits (a colour one it reduces to 8: the card says so)
    np.testing.assert_array_equal(np.asarray(ds["train"][2]["roughness"]), st.codes(2)["roughness"][..., 0])
    assert "decode=False" in (out / "README.md").read_text()


def test_renders_export_splits_images_and_aligned_maps(stores, tmp_path):
    """Every view: the stored sRGB codes (exactly), the view's aligned maps (to 16-bit rounding) and parameters,
    in the store's recorded split; shards cut where asked; `datasets` reads both splits."""
    import datasets

    from pipeline.export_parquet import write_parquet
    from storage.renders_store import RendersReader

    r = RendersReader(stores / "r.zarr")
    test = set(r.stored_split()["test_materials"])
    out = tmp_path / "r_pq"
    out.mkdir()
    # a row group and a shard per row (1 byte each), to see shards cut and named
    assert write_parquet(stores / "r.zarr", out, shard_bytes=1, group_bytes=1) == len(r) == 8
    files, tables = table(out)
    assert [f.name for f in files] == [f"{s}-0000{k}-of-00004.parquet" for s in ("test", "train") for k in range(4)]
    seen = {}
    for name, t in tables.items():
        row = t.to_pylist()[0]
        i = row["svbrdf"] * r.views + row["view"]
        seen[i] = name.split("-")[0]
        np.testing.assert_array_equal(read_raw(Blob("image", row["image"]["bytes"])), r.image_codes(row["svbrdf"])[
            row["view"]])
        want = r.maps(i)
        got = {k: read_raw(Blob(k, row[k]["bytes"])).astype(np.float64) / 65535 for k in MAPS}
        assert np.abs(got["normal"] * 2 - 1 - want.normal).max() <= 1.01 / 65535
        for k in ("diffuse", "specular", "roughness"):
            assert np.abs(got[k] - getattr(want, k)).max() <= 0.51 / 65535, k
        p = r.view_params(i)
        assert (row["zoom"], row["rotation"], row["seed"]) == (p.zoom, p.rotation, p.seed)
        assert row["material"] == " + ".join(r.presets_of_svbrdf()[row["svbrdf"]])
        assert seen[i] == ("test" if row["material"] in test else "train")
    assert sorted(seen) == list(range(8))
    ds = datasets.load_dataset(str(out))
    assert {s: ds[s].num_rows for s in ds} == {"train": 4, "test": 4}
    assert isinstance(ds["test"].features["image"], datasets.Image)
    assert np.asarray(ds["test"][0]["image"]).shape == (r.res, r.res, 3)


def test_force_replaces_only_an_export_and_bad_stores_are_one_line(stores, tmp_path, svgen_cli):
    out = tmp_path / "o"
    code, text = svgen_cli("export", stores / "v.zarr", out, "--format", "parquet", "--limit", "3")
    assert code == 0 and "wrote 3 rows" in text, text
    assert is_export(out)
    code, text = svgen_cli("export", stores / "v.zarr", out, "--format", "parquet")
    assert code == 2 and "--force" in text  # refused: out holds an export
    code, text = svgen_cli("export", stores / "v.zarr", out, "--format", "parquet", "--force")
    assert code == 0 and "wrote 4 rows" in text, text
    (out / "notes.txt").write_text("mine")
    assert not is_export(out)  # a parquet export plus a file of the user's: --force leaves it alone
    code, text = svgen_cli("export", stores / "v.zarr", out, "--format", "parquet", "--force")
    assert code == 2 and "not an export" in text and (out / "notes.txt").exists()
    code, text = svgen_cli("export", tmp_path / "missing.zarr", tmp_path / "p", "--format", "parquet")
    assert code == 2 and "Traceback" not in text and len(text.strip().splitlines()) == 1, text
    assert not (tmp_path / "p.partial").exists()


def test_cli_formats_are_the_registry():
    from pipeline.commands.export import export as cmd

    choice = next(p for p in cmd.params if p.name == "fmt").type
    assert set(choice.choices) == set(FORMATS)
