"""The sharded store layout (docs/CODECS.md, schema 3): one shard object per array per task, never two tasks in
one shard; a render killed mid-run resumes to the same bytes with shards of several SVBRDFs (and a partial last
shard); the bytes do not depend on the worker count; schema 2 (unsharded) stores stay readable."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import chunk_stats, tree_digest
from s3_fixtures import s3, s3_server  # noqa: F401  (fixtures)
from pipeline.config import RenderConfig, SampleConfig
from pipeline.render.stage import run_render
from storage.renders_store import RendersReader
from pipeline.sample import run_sample
from storage.store import DONE_DIR, MANIFEST, SMALL_SAMPLE_BYTES, open_store, partial_path, verify_store
from svcore.config import build

PRESETS = ("paint/glossy_red", "wood/mahogany_veneer")
N_SVBRDF = 6
CHUNK = 4  # tasks of 4 samples: 2 tasks, the last one a partial shard (2 samples)
RENDER = ["--config-preset", "tiny", "--res", "32", "--views", "2", "--chunk", str(CHUNK)]


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    """6 variants of 64^2 maps in 2 sample tasks (4, 2)."""
    out = tmp_path_factory.mktemp("shards_in") / "variants.zarr"
    run_sample(out, build(SampleConfig, "tiny", presets=PRESETS, per_preset=N_SVBRDF // 2, chunk=CHUNK), workers=0)
    return out


def _svgen(inp, out, *extra):
    return [sys.executable, "-c", "from pipeline.cli import main; main()", "render", str(inp), str(out), *RENDER,
            *extra]


def _render(inp, out, workers: int) -> None:
    """`svgen render` in this process (the command line a store records is the one the other runs give)."""
    from pipeline.cli import cli
    from test_bad_input import call

    code, err = call(cli, "svgen", ["render", inp, out, *RENDER, "--workers", workers])
    assert code == 0, err


@pytest.fixture(scope="module")
def reference(variants, tmp_path_factory):
    """The uninterrupted render, one process (workers=0)."""
    out = tmp_path_factory.mktemp("shards_ref") / "renders.zarr"
    _render(variants, out, 0)
    return out


def _objects(store: Path, array: str) -> list[str]:
    """The chunk objects (files) of ``array``: every file under its ``c/`` folder, relative to it."""
    root = store / array / "c"
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()) if root.exists() else []


@pytest.mark.parametrize("store", ["variants", "reference"])
def test_one_shard_object_per_array_per_task(store, request):
    """Each task wrote exactly one object per array: the shard of its samples (key c/<task>/0/...), and every
    image/map array has one for every task; no array is split into more objects than tasks."""
    path = Path(request.getfixturevalue(store))
    g = open_store(path, ("variants", "renders"))
    n, tasks = g.attrs["svgen"]["n"], -(-g.attrs["svgen"]["n"] // CHUNK)
    # 4 since #42 (same layout); version 5 changed only the blends store, 6 only renders without maps
    assert g.attrs["svgen"]["schema_version"] == 4 and g.attrs["svgen"]["chunk"] == CHUNK
    man = json.loads((path / MANIFEST).read_text())
    for name, arr in g.arrays():
        assert arr.shards is not None and arr.shards[0] == CHUNK, (name, arr.shards)
        per_sample = int(np.prod(arr.shape[1:])) * arr.dtype.itemsize
        assert arr.chunks[0] == (1 if per_sample >= SMALL_SAMPLE_BYTES else CHUNK), (name, arr.chunks)
        files = _objects(path, name)
        written = ["/".join([str(c)] + ["0"] * (arr.ndim - 1)) for c, rec in enumerate(man["arrays"][name]) if rec is not None]
        assert files == sorted(written), f"array {name!r}: objects {files}, one per task expected: {written}"
        if per_sample >= SMALL_SAMPLE_BYTES:
            assert len(files) == tasks, f"array {name!r}: {len(files)} objects for {tasks} tasks of {n} samples"
    assert verify_store(path) >= tasks


def test_sigkill_mid_render_then_rerun_gives_the_same_bytes(variants, reference, tmp_path):
    """Killed right after its first task's record (SVGEN_TEST_KILL_AT=chunk), the rerun writes the other (partial)
    shard, keeps the finished one (same inode) and ends byte-identical to the uninterrupted run."""
    out = tmp_path / "killed.zarr"
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1"}
    r = subprocess.run(_svgen(variants, out, "--workers", "0"), capture_output=True, text=True,
                       env={**env, "SVGEN_TEST_KILL_AT": "chunk"})
    assert r.returncode == -9, r.stderr
    done = partial_path(out) / DONE_DIR
    finished = sorted(int(m.name) for m in done.iterdir())
    assert finished == [0] and not out.exists()
    kept = chunk_stats(partial_path(out), finished, "image", 5)
    r = subprocess.run(_svgen(variants, out, "--workers", "0"), capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert tree_digest(out) == tree_digest(reference)
    assert chunk_stats(out, finished, "image", 5) == kept, "the rerun rewrote the shard finished before the kill"


def test_two_workers_write_the_same_bytes(variants, reference, tmp_path):
    """Tasks on 2 local dask worker processes at once (one shard each) give the one-process bytes."""
    out = tmp_path / "two.zarr"
    _render(variants, out, 2)
    assert tree_digest(out) == tree_digest(reference)


def test_s3_store_with_two_workers_has_the_local_shards(variants, reference, s3):  # noqa: F811
    """2 dask workers writing 4-SVBRDF shards straight to a loopback S3 bucket: every shard object equals the local
    one-process shard file byte for byte, and the manifests are equal (local and S3 stores share the layout)."""
    from test_store_s3 import assert_same_store

    url = s3.url("renders.zarr")
    run_render(variants, url, build(RenderConfig, "tiny", res=32, views=2, chunk=CHUNK), workers=2)
    assert_same_store(s3, url, reference)
    assert open_store(url, "renders")["image"].shards[0] == CHUNK


def test_random_reads_decode_single_svbrdfs(reference):
    """The renders reader serves every view of a sharded store; its cache unit is one SVBRDF (the inner chunk)."""
    r = RendersReader(reference)
    assert len(r) == N_SVBRDF * 2
    img = [r.image(i) for i in (11, 0, 4)]
    assert all(i.shape == (32, 32, 3) and i.mean() > 0.01 for i in img)
    assert {k[1] for k in r._cache._chunks if k[0] == "image"} == {5, 0, 2}


def test_a_schema_2_store_stays_readable(variants, reference, tmp_path, monkeypatch):
    """A store in the layout before sharding (schema 2: one plain zstd 5 chunk per task) opens, verifies, reads in
    xarray and renders to the same images as the sharded store of the same variants."""
    import xarray as xr
    from zarr.codecs import Crc32cCodec, ZstdCodec

    from storage import local as S  # where the writer looks them up (storage.store only re-exports them)

    def unsharded(spec, n, chunk):
        return {"shape": (n, *spec.shape), "chunks": (chunk, *spec.shape), "dtype": spec.dtype,
                "compressors": [ZstdCodec(level=5), Crc32cCodec()], "fill_value": 0}

    old = tmp_path / "old.zarr"
    with monkeypatch.context() as m:  # svgen as it was: schema 2, unsharded
        m.setattr(S, "array_layout", unsharded)
        m.setattr(S, "SCHEMA_VERSION", 2)
        m.setattr(S, "UNCHANGED_SCHEMA", 2)
        run_sample(old, build(SampleConfig, "tiny", presets=PRESETS, per_preset=N_SVBRDF // 2, chunk=CHUNK),
                   workers=0)
    g = open_store(old, "variants")
    assert g.attrs["svgen"]["schema_version"] == 2 and g["diffuse"].shards is None
    assert verify_store(old) == verify_store(variants)
    ds_old, ds_new = xr.open_zarr(old), xr.open_zarr(variants)
    np.testing.assert_array_equal(ds_old.diffuse.values, ds_new.diffuse.values)
    out = tmp_path / "renders.zarr"
    run_render(old, out, build(RenderConfig, "tiny", res=32, views=2, chunk=CHUNK), workers=0)
    np.testing.assert_array_equal(RendersReader(out).group["image"][:], RendersReader(reference).group["image"][:])


@pytest.mark.parametrize("backend", ["local", "s3"])
@pytest.mark.parametrize("damage,shard,samples,what", [("missing", 0, "0:4", "is missing chunk 0"),
                                                        ("missing", 1, "4:6", "is missing chunk 1"),
                                                        ("truncated", 0, "0:4", "has a changed chunk 0"),
                                                        ("truncated", 1, "4:6", "has a changed chunk 1")])
def test_a_missing_or_truncated_shard_of_several_samples_is_refused(variants, tmp_path, s3, svgen_cli,  # noqa: F811
                                                                     backend, damage, shard, samples, what):
    """A shard holds a whole task's samples (4, and the partial last one 2): one deleted or cut short, the first
    or the last, is refused by a reader in one line naming the array and every sample it held, on disk and in a
    bucket alike. (The last shard matters: a check that stops one short, or reads the sample count from the
    shards that exist, would miss it.)"""
    import shutil

    import zarr

    local = tmp_path / "v.zarr"
    shutil.copytree(variants, local)
    arr = zarr.open_group(local, mode="r")["diffuse"]
    key = f"diffuse/{arr.metadata.encode_chunk_key((shard,) + (0,) * (arr.ndim - 1))}"
    if backend == "local":
        store, obj = local, local / key
        data = obj.read_bytes()
        obj.unlink() if damage == "missing" else obj.write_bytes(data[:len(data) // 2])
    else:
        store, fs = s3.url("v.zarr"), s3.fs()
        fs.put(str(local), f"{s3.bucket}/v.zarr", recursive=True)
        obj = f"{s3.bucket}/v.zarr/{key}"
        data = fs.cat_file(obj)
        fs.rm(obj) if damage == "missing" else fs.pipe_file(obj, data[:len(data) // 2])
    code, err = svgen_cli("render", store, tmp_path / "r.zarr", *RENDER, "--workers", "0")
    assert code == 2, err
    assert f"array 'diffuse' {what} (samples {samples})" in err and err.count("\n") == 1, err
    assert not (tmp_path / "r.zarr").exists()
