"""`svgen import --layout matsynth`: parquet shards the tests write themselves with pyarrow (MatSynth's schema,
`datasets`' image encoding), against the folder importer on the same image bytes; skipped rows; filters; memory
bounded by one row; the layouts registry."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from import_fixtures import bumpy_normals, height_field, matsynth_row, matsynth_shard, png8, png16
from pipeline.config import ImportConfig
from pipeline.importer.job import run_import
from storage.svbrdf_store import SVBRDFStore
from svcore.config import build

MAPS = ("normal", "diffuse", "specular", "roughness")


def encoded(tmp: Path, a: np.ndarray, bits: int = 8) -> bytes:
    """The PNG file of ``a`` (values in [0, 1]) as bytes."""
    f = tmp / "encode.png"
    (png16 if bits == 16 else png8)(f, a)
    return f.read_bytes()


def material(tmp: Path, s: int, rng, normal: bool = True) -> dict[str, bytes]:
    """MatSynth-style maps of one material: 16-bit base colour and height, 8-bit roughness, metallic, normal."""
    metal = np.zeros((s, s))
    metal[:, s // 2:] = rng.uniform(0.5, 1)
    maps = {"basecolor": encoded(tmp, rng.random((s, s, 3)) * 0.9 + 0.05, 16),
            "roughness": encoded(tmp, rng.random((s, s))), "metallic": encoded(tmp, metal),
            "height": encoded(tmp, height_field(s)[0], 16)}
    if normal:
        maps["normal"] = encoded(tmp, (bumpy_normals(s, rng) + 1) / 2)
    return maps


def corrupt(png: bytes) -> bytes:
    """The PNG with one byte of its first IDAT chunk's data flipped: its header reads, its CRC fails."""
    i = png.index(b"IDAT") + 8
    return png[:i] + bytes([png[i] ^ 0xFF]) + png[i + 1:]


def folder(root: Path, name: str, maps: dict[str, bytes], meta: dict) -> None:
    """The same maps as a MatSynth-style folder (basecolor.png, ..., metadata.json)."""
    d = root / name
    d.mkdir(parents=True)
    for col, data in maps.items():
        (d / f"{col}.png").write_bytes(data)
    (d / "metadata.json").write_text(json.dumps(meta))


def imp(src, out, **kw):
    srcs = tuple(map(str, src)) if isinstance(src, (list, tuple)) else (str(src),)
    return run_import(out, build(ImportConfig, sources=srcs, **kw), workers=0)


def by_name(path):
    st = SVBRDFStore(path)
    return st, {m["name"]: (i, m) for i, m in enumerate(st.attrs["materials"])}


def test_parquet_rows_equal_the_folder_importers_maps(tmp_path, rng, svgen_cli):
    """Three MatSynth rows: one without normal (height-derived), one with a corrupt PNG (skipped, reported), one with
    physical_size (cropped to capture_cm). The imported maps equal the folder importer's for the same bytes."""
    s = 64
    oak, steel, clay = material(tmp_path, s, rng, normal=False), material(tmp_path, s, rng), material(tmp_path, s, rng)
    clay["roughness"] = corrupt(clay["roughness"])
    shards = tmp_path / "matsynth" / "data"
    shards.mkdir(parents=True)
    matsynth_shard(shards / "train-00000-of-00001.parquet", [
        matsynth_row("oak", "wood", oak, license="CC-BY", authors=["A. Maker"], source="polyhaven"),
        matsynth_row("steel", "metal", steel, physical_size=0.5, license="CC0", source="ambientcg"),
        matsynth_row("clay", "terracotta", clay)])
    folder(tmp_path / "folders", "oak", oak, {"category": "wood", "license": "CC-BY"})
    folder(tmp_path / "folders", "steel", steel, {"category": "metal", "license": "CC0", "physical_size_cm": 50})
    # capture_cm 25 of a 0.5 m tile: the centre half-width window; the other row keeps its whole tile
    opts = ["--size", "32", "--capture-cm", "25", "--workers", "0"]
    code, out = svgen_cli("import", tmp_path / "matsynth", tmp_path / "p.zarr", "--physical-size-unit", "m", *opts)
    assert code == 0, out
    assert "skipped train-00000-of-00001.parquet row 2 (clay): cannot read image" in out
    assert "roughness" in out.split("(clay)")[1].splitlines()[0]
    assert "(2 materials; 1 skipped, listed above)" in out
    imp(tmp_path / "folders", tmp_path / "f.zarr", size=32, capture_cm=25)
    pst, prec = by_name(tmp_path / "p.zarr")
    fst, frec = by_name(tmp_path / "f.zarr")
    assert list(prec) == ["oak", "steel"]  # store order: shard, then row
    for name in ("oak", "steel"):
        pm, fm = pst.maps(prec[name][0]), fst.maps(frec[name][0])
        for k in MAPS:
            np.testing.assert_array_equal(getattr(pm, k), getattr(fm, k), err_msg=f"{name} {k}")
        assert prec[name][1]["crop"] == frec[name][1]["crop"]
        assert prec[name][1]["normal"] == frec[name][1]["normal"]
    oak_rec, steel_rec = prec["oak"][1], prec["steel"][1]
    assert oak_rec["normal"]["from"] == "height" and steel_rec["normal"]["from"] == "normal map"
    assert steel_rec["crop"]["fraction"] == 0.5 and "physical_size_cm 50" in steel_rec["crop"]["decided_by"]
    assert oak_rec["crop"]["decided_by"] == "import.crop"
    assert oak_rec["preset"] == "wood/oak" and steel_rec["category"] == "metal"
    assert oak_rec["licence"] == "CC-BY" and oak_rec["metadata"] == {
        "name": "oak", "license": "CC-BY", "authors": ["A. Maker"], "source": "polyhaven"}
    assert steel_rec["sidecar"]["physical_size"] == 0.5 and steel_rec["sidecar"]["physical_size_unit"] == "m"
    assert oak_rec["row"] == 0 and "normal" not in oak_rec["files"] and oak_rec["bytes"]["height"] == len(oak["height"])
    assert set(oak_rec["ignored"]) == {"diffuse", "displacement", "opacity", "specular", "blend_mask"}
    skipped = pst.attrs["import"]["skipped"]
    assert [(x["row"], x["name"]) for x in skipped] == [(2, "clay")]
    assert "checksum" in skipped[0]["reason"]  # Pillow's verify: the chunk's CRC


def test_capture_cm_needs_the_unit_and_bad_sizes_are_skipped(tmp_path, rng, svgen_cli):
    """MatSynth's card states no unit for physical_size: --capture-cm without --physical-size-unit is refused (one
    line, exit 2); a non-positive physical_size is a skipped row, and only when capture_cm uses it."""
    m = material(tmp_path, 32, rng)
    shard = matsynth_shard(tmp_path / "s.parquet", [matsynth_row("a", "wood", m, physical_size=0.0),
                                                    matsynth_row("b", "wood", m, physical_size=2.0)])
    code, out = svgen_cli("import", shard, tmp_path / "x.zarr", "--size", "16", "--capture-cm", "20", "--workers", "0")
    assert code == 2 and "--physical-size-unit" in out and "Traceback" not in out, out
    assert not (tmp_path / "x.zarr").exists()
    _, recs = imp(shard, tmp_path / "y.zarr", size=16, capture_cm=20, physical_size_unit="cm", allow_upscale=True)
    assert [r["name"] for r in recs] == ["b"]
    assert SVBRDFStore(tmp_path / "y.zarr").attrs["import"]["skipped"][0]["reason"] == \
        "metadata.physical_size 0.0 is not a positive number"
    _, recs = imp(shard, tmp_path / "z.zarr", size=16)  # without capture_cm the size is not used: both rows
    assert [r["name"] for r in recs] == ["a", "b"]


def test_a_damaged_shard_is_one_line(tmp_path, rng, svgen_cli):
    shard = matsynth_shard(tmp_path / "s.parquet", [matsynth_row("a", "wood", material(tmp_path, 16, rng))])
    shard.write_bytes(shard.read_bytes()[:-100])  # the footer gone
    code, out = svgen_cli("import", shard, tmp_path / "x.zarr", "--layout", "matsynth", "--size", "16")
    assert code == 2 and "cannot read parquet" in out and "Traceback" not in out, out
    assert len(out.strip().splitlines()) == 1


def test_missing_maps_filters_and_limit(tmp_path, rng):
    """A row without base colour (or without both normal and height) is skipped; --split picks shards by the hub's
    names, --only-category by class, --limit stops the pass (a bad row after the limit is never read)."""
    m = material(tmp_path, 32, rng)
    no_relief = {k: v for k, v in m.items() if k not in ("normal", "height")}
    d = tmp_path / "data"
    d.mkdir()
    matsynth_shard(d / "train-00000-of-00002.parquet", [
        matsynth_row("t0", "wood", m), matsynth_row("t1", "stone", {k: v for k, v in m.items() if k != "basecolor"}),
        matsynth_row("t2", "stone", no_relief)], row_group_size=2)
    matsynth_shard(d / "train-00001-of-00002.parquet", [matsynth_row("t3", "stone", m), matsynth_row("t4", "wood", m),
                                                       matsynth_row("t5", "wood", {**m, "basecolor": b"junk"})])
    matsynth_shard(d / "test-00000-of-00001.parquet", [matsynth_row("e0", "metal", m)])
    _, recs = imp(d, tmp_path / "all.zarr", size=16, split="train")
    assert [r["name"] for r in recs] == ["t0", "t3", "t4"]
    skipped = SVBRDFStore(tmp_path / "all.zarr").attrs["import"]["skipped"]
    assert [(x["shard"], x["row"], x["reason"].split(":")[0]) for x in skipped] == [
        ("train-00000-of-00002.parquet", 1, "missing map"), ("train-00000-of-00002.parquet", 2, "missing map"),
        ("train-00001-of-00002.parquet", 2, "cannot read image train-00001-of-00002.parquet row 2 basecolor")]
    assert skipped[0]["reason"] == "missing map: basecolor" and skipped[1]["reason"] == "missing map: normal or height"
    _, recs = imp(d, tmp_path / "test.zarr", size=16, split="test")
    assert [r["preset"] for r in recs] == ["metal/e0"]
    _, recs = imp(d, tmp_path / "wood.zarr", size=16, only_category=["wood"], limit=2)
    assert [r["name"] for r in recs] == ["t0", "t4"]
    assert "skipped" not in SVBRDFStore(tmp_path / "wood.zarr").attrs["import"]  # t5 (junk) lies after the limit


def test_non_stationary_materials_are_cropped_at_the_centre(tmp_path, rng):
    """stationary: false overrides import.crop_centre (the window is centred); a stationary row keeps it."""
    m = material(tmp_path, 64, rng)
    shard = matsynth_shard(tmp_path / "s.parquet", [matsynth_row("still", "misc", m, stationary=True),
                                                    matsynth_row("object", "misc", m, stationary=False)])
    imp(shard, tmp_path / "corner.zarr", size=32, crop=0.5, crop_centre=[0.0, 0.0])
    imp(shard, tmp_path / "centre.zarr", size=32, crop=0.5)
    corner, crec = by_name(tmp_path / "corner.zarr")
    centre, _ = by_name(tmp_path / "centre.zarr")
    obj = corner.maps(crec["object"][0])
    np.testing.assert_array_equal(obj.diffuse, centre.maps(crec["object"][0]).diffuse)
    assert np.abs(obj.diffuse - corner.maps(crec["still"][0]).diffuse).max() > 0.1
    assert crec["object"][1]["crop"]["centre"] == [0.5, 0.5]
    assert crec["object"][1]["crop"]["centre_decided_by"].startswith("stationary: false")
    assert crec["still"][1]["crop"]["centre"] == [0.0, 0.0]


MEASURE = """
import json, sys, tracemalloc
from pathlib import Path
import pyarrow as pa
from pipeline.config import ImportConfig
from pipeline.importer.layouts import LAYOUTS
from svcore.config import build
tracemalloc.start()
out, layout = {}, LAYOUTS["matsynth"]
for shard in sys.argv[1:]:  # smallest first: Arrow's peak is the process's
    cfg = build(ImportConfig, sources=(shard,), size=32)
    tracemalloc.reset_peak()
    mats, _ = layout.find([Path(shard)], cfg)
    mats, _ = layout.check(mats, cfg)  # the plan's pass: every byte read
    rows = sum(1 for _ in layout.convert(mats, cfg))  # the chunk tasks' pass: every row decoded and converted
    out[shard] = {"rows": rows, "arrow": pa.default_memory_pool().max_memory(),
                  "python": tracemalloc.get_traced_memory()[1]}
print(json.dumps(out))
"""


def test_memory_is_bounded_by_one_row(tmp_path, rng):
    """Peak memory of an import's two passes over a one-row-group shard of 4 rows, then of 32 rows (one fresh
    process): Arrow's allocations (its pool's peak) and Python's (tracemalloc: bytes objects, numpy arrays) do not
    grow with the rows. A row holds ~1.1 MB of incompressible PNGs (three maps of ~370 KB), so reading the row
    group at once would hold ~35 MB; `datasets`' content-defined pages (at most 1 MB) hold 1 to 3 such maps."""
    m = {"basecolor": encoded(tmp_path, rng.random((352, 352, 3))),
         "roughness": encoded(tmp_path, rng.random((608, 608))), "height": encoded(tmp_path, rng.random((608, 608)))}
    row_bytes = sum(map(len, m.values()))
    shards = [str(matsynth_shard(tmp_path / f"s{n}.parquet", [matsynth_row(f"m{i}", "wood", m) for i in range(n)]))
              for n in (4, 32)]
    r = subprocess.run([sys.executable, "-c", MEASURE, *shards], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    small, large = (json.loads(r.stdout.strip().splitlines()[-1])[s] for s in shards)
    assert (small["rows"], large["rows"]) == (4, 32)
    # 28 more rows: Arrow's peak grows by less than two rows (pages fall differently), Python's (its traced total,
    # imports included) by less than a map
    assert large["arrow"] - small["arrow"] < 2 * row_bytes, (small, large, row_bytes)
    assert large["python"] - small["python"] < row_bytes / 4, (small, large, row_bytes)
    # what Arrow holds is pages and the input streams' buffers, not the row group
    assert large["arrow"] < 12 * row_bytes, (small, large, row_bytes)


def test_layouts_registry_is_the_config_choice():
    from typing import get_args

    from pipeline.config import ImportLayout
    from pipeline.importer.layouts import LAYOUTS

    assert set(get_args(ImportLayout)) == {"auto", *LAYOUTS}


@pytest.mark.parametrize("given", ["file", "folder"])
def test_auto_detects_parquet_sources(tmp_path, rng, given):
    (tmp_path / "d").mkdir()
    shard = matsynth_shard(tmp_path / "d" / "x.parquet", [matsynth_row("a", "wood", material(tmp_path, 16, rng))])
    _, recs = imp(shard if given == "file" else tmp_path / "d", tmp_path / "o.zarr", size=16)
    assert recs[0]["layout"] == "matsynth"
