"""The store life cycle: temp name, chunk markers, resume, lock, refusal of foreign/partial/corrupt stores."""
from __future__ import annotations

import numpy as np
import pytest
import zarr

from svcore.errors import StoreError
from storage.store import ArraySpec, StoreWriter, open_store, partial_path, read_region, write_chunk

ARRAYS = {"x": ArraySpec((4, 4, 3), "uint16", "test"), "seed": ArraySpec((), "uint64")}


def _fill(w: StoreWriter, chunks=None):
    for c in (w.pending() if chunks is None else chunks):
        a, b = w.chunk_range(c)
        write_chunk(w.partial, c, a, {"x": np.full((b - a, 4, 4, 3), c + 1, np.uint16),
                                       "seed": np.arange(a, b, dtype=np.uint64)})


def test_complete_store_round_trip(tmp_path):
    out = tmp_path / "s.zarr"
    with StoreWriter(out, "variants", 10, 4, ARRAYS, {"a": 1}) as w:
        assert w.n_chunks == 3 and w.pending() == [0, 1, 2]
        _fill(w)
        w.finalize({"extra": 7})
    assert not partial_path(out).exists() and not (tmp_path / "s.zarr.lock").exists()
    g = open_store(out, "variants")
    assert g.attrs["svgen"]["complete"] is True and g.attrs["extra"] == 7 and g.attrs["config"] == {"a": 1}
    assert read_region(g, "x", 8, 10)[:, 0, 0, 0].tolist() == [3, 3]
    assert g["seed"][:].tolist() == list(range(10))
    with pytest.raises(StoreError, match="is a variants store, expected a renders"):
        open_store(out, "renders")


def test_existing_output_is_refused_and_untouched(tmp_path):
    out = tmp_path / "s.zarr"
    out.mkdir()
    (out / "precious.txt").write_text("keep")
    with pytest.raises(StoreError, match="already exists"):
        StoreWriter(out, "variants", 4, 4, ARRAYS, {})
    assert (out / "precious.txt").read_text() == "keep"


def test_interrupted_store_reads_incomplete_and_resumes_only_missing_chunks(tmp_path):
    out = tmp_path / "s.zarr"
    with StoreWriter(out, "variants", 10, 4, ARRAYS, {"a": 1}) as w:
        _fill(w, [1])  # a "killed" run: one chunk written, no finalize
    with pytest.raises(StoreError, match="incomplete"):
        open_store(out, "variants")
    with pytest.raises(StoreError, match="different configuration"):
        with StoreWriter(out, "variants", 10, 4, ARRAYS, {"a": 2}):
            pass
    with StoreWriter(out, "variants", 10, 4, ARRAYS, {"a": 1}) as w:
        assert w.pending() == [0, 2] and w.done_samples() == 4
        _fill(w)
        w.finalize()
    assert open_store(out, "variants")["x"][:, 0, 0, 0].tolist() == [1] * 4 + [2] * 4 + [3] * 2


def test_second_writer_is_refused_while_first_holds_the_lock(tmp_path):
    out = tmp_path / "s.zarr"
    with StoreWriter(out, "variants", 4, 4, ARRAYS, {}):
        with pytest.raises(StoreError, match="another run is writing"):
            with StoreWriter(out, "variants", 4, 4, ARRAYS, {}):
                pass


def test_foreign_and_missing_stores_are_named(tmp_path):
    with pytest.raises(StoreError, match="no store"):
        open_store(tmp_path / "nope.zarr", "variants")
    (tmp_path / "dir").mkdir()
    with pytest.raises(StoreError, match="not a zarr v3 store"):
        open_store(tmp_path / "dir", "variants")
    g = zarr.open_group(tmp_path / "foreign.zarr", mode="w", zarr_format=3)
    g.create_array("x", shape=(2,), dtype="f4")
    zarr.consolidate_metadata(tmp_path / "foreign.zarr")
    with pytest.raises(StoreError, match="not an svgen store"):
        open_store(tmp_path / "foreign.zarr", "variants")


def test_corrupted_chunk_is_detected_and_named(tmp_path):
    out = tmp_path / "s.zarr"
    with StoreWriter(out, "variants", 8, 4, ARRAYS, {}) as w:
        _fill(w)
        w.finalize()
    chunk_file = out / "x" / "c" / "1" / "0" / "0" / "0"
    b = bytearray(chunk_file.read_bytes())
    b[len(b) // 2] ^= 0xFF
    chunk_file.write_bytes(bytes(b))
    g = open_store(out, "variants")
    assert read_region(g, "x", 0, 4)[0, 0, 0, 0] == 1  # the intact chunk still reads
    with pytest.raises(StoreError, match=r"chunk 1"):
        read_region(g, "x", 4, 8)


def test_orphaned_zarr_chunk_temp_files_are_dropped_at_finalize(tmp_path):
    """A kill while zarr writes a chunk leaves its "<key>.<uuid hex>.partial" temp file; the resumed run rewrites the
    chunk, and the finished store must not keep the orphan (it did: a SIGKILL-during-render test saw one)."""
    out = tmp_path / "s.zarr"
    with StoreWriter(out, "variants", 8, 4, ARRAYS, {}) as w:
        _fill(w, [0])
        chunk_dir = w.partial / "x" / "c" / "1" / "0" / "0"  # chunk key x/c/1/0/0/0 is a file in there
        chunk_dir.mkdir(parents=True, exist_ok=True)
        orphan = chunk_dir / "0.0e0215fc14b04c1b97c11bb31a2f9130.partial"
        orphan.write_bytes(b"half a chunk")
        keep = w.partial / "notes.partial"  # not zarr's temp pattern: not ours to delete
        keep.write_text("x")
    with StoreWriter(out, "variants", 8, 4, ARRAYS, {}) as w:
        _fill(w)
        w.finalize()
    files = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
    assert not any(f.endswith("0e0215fc14b04c1b97c11bb31a2f9130.partial") for f in files), files
    assert "notes.partial" in files
    assert open_store(out, "variants")["x"][:, 0, 0, 0].tolist() == [1] * 4 + [2] * 4


def test_local_writer_refuses_an_object_url_and_the_door_picks_the_backend(tmp_path):
    """storage.store.open_writer chooses the backend by the path; the local writer alone does not take s3:// (#26)."""
    from storage.store import open_writer
    from storage.store_object import ObjectStoreWriter

    with pytest.raises(StoreError, match="open_writer"):
        StoreWriter("s3://bucket/v.zarr", "variants", 4, 4, ARRAYS, {})
    assert type(open_writer(tmp_path / "v.zarr", "variants", 4, 4, ARRAYS, {})) is StoreWriter
    assert issubclass(ObjectStoreWriter, StoreWriter)


def test_a_program_that_never_opened_an_object_store_exits_without_a_traceback():
    """storage.objstore closes the S3 sessions zarr opened at exit; a program that opened none (most: any script that
    imports the storage package for a local store) must not import zarr at exit, which Python refuses then
    ("can't register atexit after shutdown", a traceback on every exit)."""
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-c", "import storage.objstore"], capture_output=True, text=True)
    assert r.returncode == 0 and r.stderr == "", r.stderr
