"""storage.local.encode_shard (#42) writes the bytes zarr writes, for every store kind the stages write through it.

The direct shard encoder replaced zarr's write of whole shards (sample, blend, stress, render): the chunk files, and
with them every store's manifest, must stay identical. Each case writes the same values once through zarr and once
through the stage's write_chunk and compares the files byte for byte, including the last, partial shard; values zarr
would leave out of a shard (an all-fill-value inner chunk) must go to zarr.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import zarr

from storage import local, renders_store
from storage.svbrdf_store import array_specs

N, CHUNK, SIZE = 11, 4, 48  # three shards, the last one partial; maps of one inner chunk per sample


def _values(spec, n, rng):
    shape = (n, *spec.shape)
    dt = np.dtype(spec.dtype)
    # few distinct values: zstd compresses them (random bytes are stored raw, at any level)
    if dt.kind == "f":
        v = np.round(rng.standard_normal(shape), 1).astype(dt)
        v.reshape(n, -1)[:, -1] = np.nan  # params: NaN past a preset's parameters
        return v
    return rng.integers(1, 8, size=shape, dtype=dt)


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and "/c/" in str(p.relative_to(root)).replace("\\", "/") + "/"
            and not p.name.endswith(".json")}


def _group(path: Path, arrays) -> zarr.Group:
    g = zarr.open_group(path, mode="w")
    local.create_arrays(g, arrays, N, CHUNK)
    return g


#: arrays the direct encoder leaves to zarr (none since the renders' uint8 image, whose "bytes" codec zarr writes
#: without an endian setting, goes through it too)
ZARR_WRITES: set[str] = set()


def _specs(kind: str):
    if kind == "renders":  # 2 views at 32², the base maps beside them
        return renders_store.array_specs(2, 32, SIZE)
    return array_specs(kind, SIZE, max_params=5 if kind == "variants" else 0)


@pytest.mark.parametrize("kind", ["variants", "blends", "stress", "renders"])
def test_same_bytes_as_zarr(tmp_path, kind):
    arrays = _specs(kind)
    rng = np.random.default_rng(0)
    values = {name: _values(spec, N, rng) for name, spec in arrays.items()}
    ref, fast = _group(tmp_path / "ref", arrays), _group(tmp_path / "fast", arrays)
    assert {fast[name].chunks[0] for name in arrays} == {1, CHUNK}  # both layouts of array_layout
    (tmp_path / "fast" / local.DONE_DIR).mkdir()
    for c in range(-(-N // CHUNK)):
        start, stop = c * CHUNK, min(N, (c + 1) * CHUNK)
        for name, v in values.items():
            ref[name][start:stop] = v[start:stop]
            direct = local.encode_shard(fast[name], c, start, v[start:stop]) is not None
            assert direct == (name not in ZARR_WRITES), name
        local.write_chunk(tmp_path / "fast", c, start, {name: v[start:stop] for name, v in values.items()})
    a, b = _files(tmp_path / "ref"), _files(tmp_path / "fast")
    assert a and a.keys() == b.keys()
    assert [k for k in a if a[k] != b[k]] == []
    # and zarr reads back what was written
    g = zarr.open_group(tmp_path / "fast", mode="r")
    for name, v in values.items():
        np.testing.assert_array_equal(g[name][:], v)


def test_fill_value_chunks_go_to_zarr(tmp_path):
    """A sample that is all fill value (zarr leaves it out of the shard) and a misaligned region: zarr writes them."""
    arrays = {k: v for k, v in array_specs("blends", SIZE).items() if k in ("roughness", "seed")}
    g = _group(tmp_path / "s", arrays)
    r = np.ones((CHUNK, *arrays["roughness"].shape), np.uint16)
    r[1] = 0
    assert local.encode_shard(g["roughness"], 0, 0, r) is None
    assert local.encode_shard(g["seed"], 0, 0, np.zeros(CHUNK, np.uint64)) is None
    assert local.encode_shard(g["seed"], 0, 1, np.ones(CHUNK - 1, np.uint64)) is None  # not the whole shard
    assert local.encode_shard(g["seed"], 0, 0, np.ones(CHUNK, np.int64)) is None  # zarr would cast
    assert local.encode_shard(g["seed"], 0, 0, np.ones(CHUNK, np.uint64)) is not None
