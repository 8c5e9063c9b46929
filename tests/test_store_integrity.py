"""Nothing lost, nothing silent (issue 15): chunk manifests refuse damaged stores in every reader; a kill during
store creation leaves a store the rerun of the same command simply finishes."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest
import zarr

from conftest import tree_digest
from svcore.errors import StoreError
from storage.store import MANIFEST, open_store, partial_path, verify_store
from train.cli import svtrain

SAMPLE = ["sample", "--config-preset", "tiny", "--per-preset", "2", "--chunk", "1", "--workers", "0",
          "--preset", "paint/glossy_red", "--preset", "wood/oak_planks"]
SMALL_FIT = ["--set", "model.base_width=4", "--set", "model.max_width=8", "--set", "model.levels=3",
             "--set", "data.crop=16", "--set", "data.holdout=0.5", "--set", "optim.batch_size=1",
             "--workers", "0", "--no-compile", "--iterations", "1"]


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """A variants store (4 samples, one per chunk) and its renders store (chunk 1, 1 view at 16^2)."""
    from pipeline.cli import cli
    from test_bad_input import call

    d = tmp_path_factory.mktemp("integrity")
    code, err = call(cli, "svgen", [SAMPLE[0], d / "v.zarr", *SAMPLE[1:]])
    assert code == 0, err
    code, err = call(cli, "svgen", ["render", d / "v.zarr", d / "r.zarr", "--config-preset", "tiny", "--views", "1",
                                    "--res", "16", "--chunk", "1", "--workers", "0"])
    assert code == 0, err
    return d


def _damaged(stores, tmp_path, name, array, chunk):
    """A copy of store ``name`` with chunk ``chunk`` of ``array`` deleted."""
    dst = tmp_path / name
    shutil.copytree(stores / name, dst)
    g = zarr.open_group(dst, mode="r")
    key = g[array].metadata.encode_chunk_key((chunk,) + (0,) * (g[array].ndim - 1))
    os.remove(dst / array / key)
    return dst


@pytest.mark.parametrize("array", ["diffuse", "roughness", "seed", "normal"])
def test_every_svbrdf_reader_refuses_a_store_with_a_missing_chunk(stores, tmp_path, array, svgen_cli):
    v = _damaged(stores, tmp_path, "v.zarr", array, 2)
    for args in (["render", v, tmp_path / "r.zarr", "--config-preset", "tiny", "--views", "1", "--res", "16",
                  "--workers", "0"],
                 ["blend", v, tmp_path / "b.zarr", "--config-preset", "tiny", "--workers", "0"]):
        code, err = svgen_cli(*args)
        assert code == 2, err
        assert f"array '{array}' is missing chunk 2 (samples 2:3)" in err and err.count("\n") == 1, err
        assert not (tmp_path / "r.zarr").exists() and not (tmp_path / "b.zarr").exists()


@pytest.mark.parametrize("array", ["image", "diffuse", "source_seed"])
def test_export_and_training_refuse_a_renders_store_with_a_missing_chunk(stores, tmp_path, array, svgen_cli):
    from test_bad_input import call

    r = _damaged(stores, tmp_path, "r.zarr", array, 1)
    code, err = svgen_cli("export", r, tmp_path / "x")
    assert code == 2 and f"array '{array}' is missing chunk 1 (samples 1:2)" in err, err
    code, err = call(svtrain, "svtrain", ["fit", "--store", r, "--out", tmp_path / "run", *SMALL_FIT])
    assert code == 2 and f"array '{array}' is missing chunk 1" in err, err
    assert not (tmp_path / "run").exists()


def test_the_manifest_lists_fill_value_chunks_and_refuses_one_that_appears(stores, tmp_path):
    man = json.loads((stores / "r.zarr" / MANIFEST).read_text())
    assert man["arrays"]["input"] == [None] * 4  # one input store: all zeros, which zarr never writes
    assert all(r is not None for r in man["arrays"]["image"])
    open_store(stores / "r.zarr", "renders")  # fill-value chunks are not "missing"
    r = tmp_path / "r.zarr"
    shutil.copytree(stores / "r.zarr", r)
    (r / "input" / "c").mkdir(parents=True)
    shutil.copy(r / "source_seed" / "c" / "1", r / "input" / "c" / "1")
    with pytest.raises(StoreError, match="array 'input' has a chunk the manifest does not list: 1"):
        open_store(r, "renders")


def test_verify_store_rehashes_what_the_cheap_check_does_not(stores, tmp_path):
    v = tmp_path / "v.zarr"
    shutil.copytree(stores / "v.zarr", v)
    assert verify_store(v) == 4 * 8  # 4 chunks x 8 arrays (7 and preset_name: storage.labels), none all fill value
    f = v / "diffuse" / "c" / "1" / "0" / "0" / "0"
    data = bytearray(f.read_bytes())
    data[len(data) // 2] ^= 0xFF  # same size: the open-time stat cannot see it
    f.write_bytes(bytes(data))
    open_store(v, "variants")
    with pytest.raises(StoreError, match="array 'diffuse' chunk 1 .samples 1:2. does not match its checksum"):
        verify_store(v)


def test_a_store_without_manifest_is_refused_with_a_recreate_line(stores, tmp_path):
    v = tmp_path / "v.zarr"
    shutil.copytree(stores / "v.zarr", v)
    os.remove(v / MANIFEST)
    with pytest.raises(StoreError, match="older svgen without a chunk manifest.*re-create it"):
        open_store(v, "variants")


def test_a_partial_directory_given_as_input_gets_a_clear_line(stores, tmp_path, svgen_cli):
    p = tmp_path / "v.zarr.partial"
    shutil.copytree(stores / "v.zarr", p)
    code, err = svgen_cli("render", p, tmp_path / "r.zarr", "--config-preset", "tiny", "--workers", "0")
    assert code == 2 and "is an unfinished store" in err and "rerun its command to resume" in err, err


# --- item 2: a kill during creation -----------------------------------------------------------------------------

def _sample_cmd(out):
    return [sys.executable, "-c", "from pipeline.cli import main; main()", SAMPLE[0], str(out), *SAMPLE[1:]]


def test_sigkill_during_store_creation_then_rerun_just_works(stores, tmp_path):
    out = tmp_path / "v.zarr"
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "SVGEN_TEST_KILL_AT": "create"}
    r = subprocess.run(_sample_cmd(out), capture_output=True, text=True, env=env)
    assert r.returncode == -9, r.stderr  # killed by the hook: the group and attributes exist, not yet renamed
    assert not out.exists()
    env.pop("SVGEN_TEST_KILL_AT")
    r = subprocess.run(_sample_cmd(out), capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert tree_digest(out) == tree_digest(stores / "v.zarr")
    assert [p.name for p in tmp_path.iterdir()] == ["v.zarr"]


def test_a_partial_left_between_zarr_json_and_its_attributes_is_restarted(stores, tmp_path, svgen_cli):
    """What an older svgen left when killed ~0.8 s into a run: the group's zarr.json with empty attributes."""
    out = tmp_path / "v.zarr"
    g = zarr.open_group(partial_path(out), mode="w", zarr_format=3)
    g.create_array("diffuse", shape=(4, 64, 64, 3), chunks=(1, 64, 64, 3), dtype="uint16")
    assert json.loads((partial_path(out) / "zarr.json").read_text())["attributes"] == {}
    code, err = svgen_cli(SAMPLE[0], out, *SAMPLE[1:])
    assert code == 0, err
    assert tree_digest(out) == tree_digest(stores / "v.zarr")


def test_a_partial_started_by_an_older_svgen_finishes_with_a_manifest(tmp_path):
    """Markers that say only "ok" and schema 1: the resumed run hashes those chunks at finalize."""
    import numpy as np

    from storage.store import DONE_DIR, ArraySpec, StoreWriter, write_chunk

    arrays = {"x": ArraySpec((2,), "uint16"), "seed": ArraySpec((), "uint64")}
    out = tmp_path / "s.zarr"
    with StoreWriter(out, "variants", 4, 2, arrays, {"a": 1}) as w:
        write_chunk(w.partial, 0, 0, {"x": np.ones((2, 2), np.uint16), "seed": np.arange(2, dtype=np.uint64)})
        (w.partial / DONE_DIR / "0").write_text("ok")
        g = zarr.open_group(w.partial, mode="r+")
        g.attrs["svgen"] = {**g.attrs["svgen"], "schema_version": 1}
    with StoreWriter(out, "variants", 4, 2, arrays, {"a": 1}) as w:
        assert w.pending() == [1]
        write_chunk(w.partial, 1, 2, {"x": np.ones((2, 2), np.uint16), "seed": np.arange(2, 4, dtype=np.uint64)})
        w.finalize()
    assert verify_store(out) == 4
