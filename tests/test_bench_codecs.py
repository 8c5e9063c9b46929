"""experiments/store_codecs/bench_codecs.py (#12's finished codec measurement) on tiny real stores: every codec
and layout round-trips the data bit for bit, the bytes and objects it reports are those of the files it wrote, the
layout it names is the one in the store's metadata, and a lossy pipeline makes it fail. (Speed is never asserted:
experiments/store_codecs/results/codecs.json.)"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import zarr

from pipeline.config import SampleConfig
from pipeline.sample import run_sample
from storage.store import open_store
from svcore.config import build

ROOT = Path(__file__).resolve().parents[1]
EXPERIMENT = ROOT / "experiments" / "store_codecs"
SCRIPT = EXPERIMENT / "bench_codecs.py"
CODECS = "zstd5,blosc-lz4-bit,blosc-zstd-shuf,delta-zstd3"


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """8 variants (2 presets x 4: the sample stage's task is 8; 64^2 maps, `svgen sample` code) and their renders
    (`svgen render`, tiny preset: 2 views of 64^2 each)."""
    from pipeline.cli import cli
    from svcore.cli import run_cli

    d = tmp_path_factory.mktemp("codecs")
    variants, renders = d / "variants.zarr", d / "renders.zarr"
    run_sample(variants, build(SampleConfig, "tiny", presets=("paint/glossy_red", "metal/aluminium_plate"),
                               per_preset=4), workers=0)
    assert run_cli(cli, "svgen", ["render", str(variants), str(renders), "--config-preset", "tiny", "--chunk", "1",
                                  "--workers", "0"]) == 0
    return variants, renders


@pytest.fixture(scope="module")
def run(stores, tmp_path_factory):
    """The benchmark on both stores, 8 samples, one rep, every written store kept."""
    variants, renders = stores
    out = tmp_path_factory.mktemp("out")
    r = subprocess.run([sys.executable, str(SCRIPT), "--renders", str(renders), "--variants", str(variants),
                        "--samples", "8", "--reps", "1", "--codecs", CODECS, "--out", str(out / "codecs.json"),
                        "--keep", str(out / "kept"), "--note", "test"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads((out / "codecs.json").read_text()), out


def test_every_codec_and_layout_round_trips_bit_for_bit(stores, run):
    """Independent of the script's own check: each kept store holds exactly the source samples it measured."""
    res, out = run
    for label, src in zip(("variants", "renders"), stores):
        d = res["stores"][label]
        g = open_store(src, label)
        idx = d["sample_indices"]
        rows = d["rows"]
        assert {(r["codec"], r["layout"]) for r in rows} == \
            {(c, lay) for c in CODECS.split(",") for lay in {r["layout"] for r in rows}}
        assert len({r["layout"] for r in rows}) >= 2 and all(r["lossless"] for r in rows)
        for r in rows:
            kept = zarr.open_group(out / "kept" / label / f"{r['codec']}-{r['layout']}.zarr", mode="r")
            for name in d["arrays"]:
                want = g[name].oindex[np.asarray(idx)]
                got = kept[name][:]
                assert got.dtype == want.dtype and got.tobytes() == want.tobytes(), (label, r["codec"], name)


def test_bytes_and_objects_are_those_of_the_files_written(run):
    res, out = run
    for label, d in res["stores"].items():
        views = d["views"]
        for r in d["rows"]:
            root = out / "kept" / label / f"{r['codec']}-{r['layout']}.zarr"
            files = [p for p in root.rglob("*") if p.is_file() and p.name != "zarr.json"]
            assert r["objects"] == len(files) > 0
            assert r["objects_per_10k_views"] == pytest.approx(len(files) * 10_000 / views)
            assert r["bytes_per_view"] * views == pytest.approx(sum(p.stat().st_size for p in files))
            for name, b in r["bytes_per_view_by_array"].items():
                assert b * views == pytest.approx(sum(p.stat().st_size for p in files
                                                      if p.relative_to(root).parts[0] == name))


def test_the_layout_and_codec_named_are_in_the_metadata(run):
    """A sharded row's image is a sharding_indexed array with one shard per task and one sample per inner chunk;
    an unsharded row's chunk is the task; the codec's name appears in the codec chain."""
    res, out = run
    key = {"zstd5": "zstd", "blosc-lz4-bit": "blosc", "blosc-zstd-shuf": "blosc", "delta-zstd3": "numcodecs.delta"}
    d = res["stores"]["renders"]
    for r in d["rows"]:
        meta = json.loads((out / "kept" / "renders" / f"{r['codec']}-{r['layout']}.zarr" / "image" /
                           "zarr.json").read_text())
        outer = meta["chunk_grid"]["configuration"]["chunk_shape"][0]
        codecs = meta["codecs"]
        assert outer == r["task_samples"]
        if r["sharded"]:
            assert codecs[0]["name"] == "sharding_indexed"
            assert codecs[0]["configuration"]["chunk_shape"][0] == r["inner_chunk_samples"] == 1
            codecs = codecs[0]["configuration"]["codecs"]
        names = [c["name"] for c in codecs]
        assert key[r["codec"]] in names and names[-1] == "crc32c", (r["codec"], names)
    assert res["chosen"]["codec"] in CODECS.split(",") and res["chosen"]["rule"]
    assert res["note"] == "test" and res["machine"]["cpus"] >= 1


def test_a_lossy_pipeline_fails_the_benchmark(stores, tmp_path, monkeypatch):
    """The lossless check can fail: a pipeline that halves the 8-bit image (FixedScaleOffset, scale 0.5)."""
    from zarr.codecs import Crc32cCodec, ZstdCodec
    from zarr.codecs.numcodecs import FixedScaleOffset

    monkeypatch.syspath_prepend(str(EXPERIMENT))
    import bench_codecs

    def lossy(dtype, ndim):
        f = [FixedScaleOffset(offset=0, scale=0.5, dtype=dtype.str, astype=dtype.str)] if dtype == np.uint8 else []
        return f, [ZstdCodec(level=1), Crc32cCodec()]

    data, _ = bench_codecs.load(stores[1], "renders", 2)
    codec = bench_codecs.Codec("halve", "zstd", "lossy on purpose", lossy)
    with pytest.raises(AssertionError, match="not lossless on \\['image'\\]"):
        bench_codecs.measure(data, 2, codec, bench_codecs.Layout("chunked", 2, 2, False), 1, tmp_path)


def test_chart_draws_from_the_results(run, tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(EXPERIMENT))
    import chart_codecs

    res, out = run
    png = chart_codecs.plot(out / "codecs.json", tmp_path / "chart_codecs.png")
    assert png.stat().st_size > 10_000


def test_the_end_to_end_estimate_swaps_the_stores_own_write_for_the_chosen_one():
    """render.json is measured with the stores' codec (zstd 3 in 64-SVBRDF shards since #12): the estimate takes
    that write out and puts the chosen codec's in, never the pre-#12 zstd 5 write (which render.json no longer
    pays). Rows built by hand: the numbers are chosen so that each wrong baseline gives another estimate."""
    sys.path.insert(0, str(EXPERIMENT))
    import bench_codecs

    def row(codec, layout, task, write, kb=190.0, read=0.001):
        return {"codec": codec, "layout": layout, "task_samples": task, "inner_chunk_samples": 1,
                "bytes_per_view": kb * 1000, "write_cpu_s_per_view": write, "read_cpu_s_per_view": read,
                "write_read_cpu_s_per_view": write + read,
                "objects_per_10k_views": 172.0 if layout == "shard=64" else 5312.0}

    ours = bench_codecs.stores_codec()  # read from storage/renders_store.py (the images: zstd3 since #12)
    assert ours in bench_codecs.CODECS and ours != bench_codecs.TODAY
    rows = [row(bench_codecs.TODAY, "chunked", 2, 0.009), row(ours, "shard=2", 2, 0.005),
            row(ours, "shard=64", 64, 0.004), row("delta-zstd1", "shard=64", 64, 0.001)]
    chosen = bench_codecs.choose(rows, 0.015)
    assert chosen["codec"] == "delta-zstd1"
    assert chosen["end_to_end_cpu_s_per_view_estimate"] == pytest.approx(0.015 - 0.004 + 0.001)
    assert f"{ours} shard=64" in chosen["end_to_end_note"] and chosen["stores_codec"] == ours
