"""zarr v3 stores that never look complete before they are.

Life of a store written by a stage:

1. :class:`StoreWriter` creates ``<out>.partial/`` (a zarr v3 group), takes an
   exclusive ``flock`` on ``<out>.lock`` beside it (a second run on the same
   output is refused; the kernel drops the lock when a run is SIGKILLed), and
   creates every array up front, chunked along the sample axis.
2. Workers write whole chunks with :func:`write_chunk` (aligned regions of the
   ``zarr.Array``, never ``da.to_zarr``: DESIGN.md) and then drop a marker file
   ``.done/<chunk>``; a marker exists only after its chunk's bytes are on disk.
3. :meth:`StoreWriter.finalize` checks every marker, writes ``complete: true``,
   consolidates metadata and renames ``.partial`` into place.

A rerun after a kill finds the ``.partial`` store, checks that it was started
by the same configuration (a hash of it) and writes only the chunks without a
marker. Chunks carry a CRC32C checksum (zarr codec), so a corrupted chunk is
detected on read and named by :func:`read_region`.
"""
from __future__ import annotations

import fcntl
import hashlib
import json
import os
import re
import shutil
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import zarr
from zarr.codecs import Crc32cCodec, ZstdCodec

from svcore.errors import StoreError

SCHEMA_VERSION = 1
PARTIAL_SUFFIX = ".partial"
#: the temporary name of a chunk zarr's LocalStore is writing (zarr/storage/_local.py: ``.{uuid4 hex}.partial``).
ZARR_TMP = re.compile(r"\.[0-9a-f]{32}\.partial$")
LOCK_SUFFIX = ".lock"
DONE_DIR = ".done"

# zarr warns that consolidated metadata is not in the v3 spec yet; we use it knowingly.
warnings.filterwarnings("ignore", message="Consolidated metadata is currently not part", category=UserWarning)


@dataclass(frozen=True)
class ArraySpec:
    """One per-sample array of a store.

    Attributes:
        shape: shape of ONE sample, e.g. (256, 256, 3); the store array is (N, *shape).
        dtype: numpy dtype name on disk.
        encoding: how values map to meaning, e.g. "linear [0,1] as uint16/65535".
        space: colour space or "n/a".
        chunk_samples: chunk length along the sample axis; None uses the store's chunk.
    """

    shape: tuple[int, ...]
    dtype: str
    encoding: str = ""
    space: str = "n/a"


def config_hash(config: dict) -> str:
    """Stable hash of a JSON-able configuration (used to match a resumed run to its partial store)."""
    return hashlib.sha256(json.dumps(config, sort_keys=True, default=str).encode()).hexdigest()[:16]


def library_versions() -> dict[str, str]:
    """Versions of the libraries that shape the bytes of a store."""
    import importlib.metadata as md

    out = {}
    for pkg in ("svgen", "numpy", "zarr", "dask", "mitsuba", "drjit", "colour-science", "torch"):
        try:
            out[pkg] = md.version(pkg)
        except md.PackageNotFoundError:
            pass
    return out


def partial_path(path: str | os.PathLike) -> Path:
    p = Path(path)
    return p.with_name(p.name + PARTIAL_SUFFIX)


def _compressors():
    # zstd: good ratio on maps/renders at speed; CRC32C: detects corrupted chunks on read.
    return [ZstdCodec(level=5), Crc32cCodec()]


class StoreWriter:
    """Create or resume a partial store for a stage (use as a context manager).

    Args:
        path: final store path (must not exist).
        kind: store kind ("variants", "blends", "renders", ...), checked by readers.
        n: number of samples.
        chunk: samples per chunk (one worker task writes one whole chunk).
        arrays: name -> :class:`ArraySpec`.
        config: the resolved stage configuration; its hash decides whether a partial store may be resumed.
        attrs: further attributes (parameters, seeds, tables) written at creation.
    """

    def __init__(self, path, kind: str, n: int, chunk: int, arrays: dict[str, ArraySpec], config: dict,
                 attrs: dict | None = None):
        self.final = Path(path)
        self.partial = partial_path(self.final)
        self.lockfile = self.final.with_name(self.final.name + LOCK_SUFFIX)
        self.kind, self.n, self.chunk = kind, int(n), int(chunk)
        self.arrays = arrays
        self.config = config
        self.hash = config_hash(config)
        self.attrs = attrs or {}
        self._lock_fd: int | None = None
        if n <= 0:
            raise StoreError(f"nothing to write: {kind} store with {n} samples")
        if self.final.exists():
            raise StoreError(f"output {self.final} already exists; choose another path or delete it")

    # -- lifecycle -------------------------------------------------------------------------------
    def __enter__(self) -> "StoreWriter":
        self.final.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.lockfile, os.O_CREAT | os.O_RDWR, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise StoreError(f"another run is writing {self.final} (lock held on {self.lockfile})") from None
        self._lock_fd = fd
        if self.final.exists():  # finished by another run while we waited for the lock
            self.__exit__()
            raise StoreError(f"output {self.final} already exists; choose another path or delete it")
        try:
            self.partial.mkdir(exist_ok=True)
            if (self.partial / "zarr.json").exists():
                self._check_resumable()
            else:
                self._create()
            (self.partial / DONE_DIR).mkdir(exist_ok=True)
        except BaseException:
            self.__exit__()  # keep whatever is there: it may be another configuration's resumable work
            raise
        return self

    def __exit__(self, exc_type=None, *exc) -> None:
        if exc_type is not None and self._lock_fd is not None and self.partial.exists() and \
                self.done_samples() == 0:
            # failed before any chunk was written (bad option, unreachable scheduler ...): nothing to resume,
            # so leave nothing behind
            shutil.rmtree(self.partial, ignore_errors=True)
            os.remove(self.lockfile)
        if self._lock_fd is not None:
            fcntl.flock(self._lock_fd, fcntl.LOCK_UN)
            os.close(self._lock_fd)
            self._lock_fd = None

    def _create(self) -> None:
        g = zarr.open_group(self.partial, mode="w", zarr_format=3)
        for name, spec in self.arrays.items():
            g.create_array(name, shape=(self.n, *spec.shape), chunks=(self.chunk, *spec.shape), dtype=spec.dtype,
                           compressors=_compressors(), fill_value=0, dimension_names=None)
        g.attrs.update({
            "svgen": {
                "kind": self.kind, "schema_version": SCHEMA_VERSION, "complete": False, "config_hash": self.hash,
                "n": self.n, "chunk": self.chunk,
                "arrays": {k: {"shape": list(v.shape), "dtype": v.dtype, "encoding": v.encoding, "space": v.space}
                           for k, v in self.arrays.items()},
                "versions": library_versions(),
            },
            "config": self.config,
            **self.attrs,
        })

    def _check_resumable(self) -> None:
        try:
            meta = dict(zarr.open_group(self.partial, mode="r").attrs).get("svgen", {})
        except Exception as e:
            raise StoreError(f"{self.partial} exists but cannot be read ({e}); delete it to start over") from None
        if meta.get("kind") != self.kind or meta.get("config_hash") != self.hash:
            raise StoreError(f"{self.partial} was started with a different configuration; rerun with the same options "
                             "to resume, or delete it to start over")

    # -- chunks ----------------------------------------------------------------------------------
    @property
    def n_chunks(self) -> int:
        return -(-self.n // self.chunk)

    def chunk_range(self, c: int) -> tuple[int, int]:
        return c * self.chunk, min(self.n, (c + 1) * self.chunk)

    def pending(self) -> list[int]:
        """Chunk ids without a completion marker."""
        done = {p.name for p in (self.partial / DONE_DIR).iterdir()} if (self.partial / DONE_DIR).exists() else set()
        return [c for c in range(self.n_chunks) if str(c) not in done]

    def done_samples(self) -> int:
        """Samples already written (by an interrupted run being resumed)."""
        return self.n - sum(b - a for a, b in map(self.chunk_range, self.pending()))

    def finalize(self, attrs: dict | None = None) -> Path:
        """Mark complete, consolidate metadata and move into place. Returns the final path."""
        missing = self.pending()
        if missing:
            raise StoreError(f"cannot finalize {self.final}: chunks {missing[:5]}... are not written")
        g = zarr.open_group(self.partial, mode="r+")
        meta = dict(g.attrs)
        meta.update(attrs or {})
        meta["svgen"] = {**meta["svgen"], "complete": True}
        g.attrs.put(meta)
        shutil.rmtree(self.partial / DONE_DIR)
        # zarr's LocalStore writes each chunk to "<key>.<uuid hex>.partial" and renames it: a kill mid-write leaves
        # that file behind, and the resumed run rewrites the chunk under its real key. Drop the orphans so the
        # finished store holds exactly what a clean run writes (tests/test_dvc_pipeline.py, SIGKILL during render).
        for orphan in self.partial.rglob("*.partial"):
            if orphan.is_file() and ZARR_TMP.search(orphan.name):
                orphan.unlink()
        zarr.consolidate_metadata(self.partial)
        os.replace(self.partial, self.final)  # still under the lock: nobody else can have made final
        os.remove(self.lockfile)
        self.__exit__()
        return self.final


def write_chunk(partial: str | os.PathLike, c: int, start: int, data: dict[str, np.ndarray]) -> None:
    """Write one whole chunk (called in workers) and then its completion marker.

    Args:
        partial: the ``.partial`` store directory.
        c: chunk id.
        start: first sample index of the chunk.
        data: array name -> (n_in_chunk, *sample_shape) values already in the on-disk dtype.
    """
    g = zarr.open_group(partial, mode="r+")
    for name, arr in data.items():
        g[name][start:start + len(arr)] = arr
    marker = Path(partial) / DONE_DIR / str(c)
    tmp = marker.with_suffix(".tmp")
    tmp.write_text("ok")
    os.replace(tmp, marker)


def open_store(path: str | os.PathLike, kind: str | tuple[str, ...]) -> zarr.Group:
    """Open a complete svgen store of the given kind(s) read-only.

    Raises:
        StoreError: missing, still partial, foreign, of another kind, newer schema, or incomplete.
    """
    p = Path(path)
    kinds = (kind,) if isinstance(kind, str) else tuple(kind)
    want = " or ".join(kinds)
    if not p.exists():
        if partial_path(p).exists():
            raise StoreError(f"{p} is incomplete (an interrupted run left {partial_path(p)}); rerun its command to resume")
        raise StoreError(f"no store at {p}")
    if not (p / "zarr.json").exists():
        raise StoreError(f"{p} is not a zarr v3 store (expected a {want} store)")
    try:
        g = zarr.open_consolidated(p, mode="r", zarr_format=3)
        meta = dict(g.attrs).get("svgen")
    except Exception as e:
        raise StoreError(f"{p} cannot be opened as a zarr v3 store: {e}") from None
    if not isinstance(meta, dict) or "kind" not in meta:
        raise StoreError(f"{p} is not an svgen store (no svgen attributes); expected a {want} store")
    if meta["kind"] not in kinds:
        raise StoreError(f"{p} is a {meta['kind']} store, expected a {want} store")
    if meta.get("schema_version", 0) > SCHEMA_VERSION:
        raise StoreError(f"{p} has schema version {meta['schema_version']}, newer than this svgen ({SCHEMA_VERSION})")
    if not meta.get("complete"):
        raise StoreError(f"{p} is not marked complete")
    for name in meta.get("arrays", {}):
        if name not in g:
            raise StoreError(f"{p} lacks its array {name!r}")
    return g


def read_region(g: zarr.Group, name: str, start: int, stop: int) -> np.ndarray:
    """Read samples [start, stop) of an array, naming the chunk if it is corrupt."""
    try:
        return g[name][start:stop]
    except Exception as e:
        chunk = g[name].chunks[0]
        raise StoreError(f"corrupt data in {g.store} array {name!r}, samples {start}:{stop} "
                         f"(chunk {start // chunk}): {e}") from None


class ChunkCache:
    """Whole decoded chunks of a store's arrays, kept up to a byte budget (FIFO eviction).

    Random access by sample (blending random pairs, a training loader drawing random views) would otherwise
    decompress a whole chunk, and pay zarr's per-call overhead, for every single sample.

    Args:
        group: an open store.
        budget_bytes: decoded bytes kept at most.
    """

    def __init__(self, group: zarr.Group, budget_bytes: int = 3 << 30):
        self.group, self.budget = group, int(budget_bytes)
        self._chunks: dict[tuple[str, int], np.ndarray] = {}
        self._bytes = 0
        self._len = {}

    def chunk(self, name: str, c: int) -> np.ndarray:
        """Chunk ``c`` of array ``name`` along the sample axis (read once, then from memory)."""
        key = (name, c)
        if key not in self._chunks:
            n = self._chunk_len(name)
            a = read_region(self.group, name, c * n, (c + 1) * n)
            while self._chunks and self._bytes + a.nbytes > self.budget:
                self._bytes -= self._chunks.pop(next(iter(self._chunks))).nbytes
            self._chunks[key] = a
            self._bytes += a.nbytes
        return self._chunks[key]

    def sample(self, name: str, i: int) -> np.ndarray:
        """Sample ``i`` of array ``name``."""
        n = self._chunk_len(name)
        return self.chunk(name, i // n)[i % n]

    def _chunk_len(self, name: str) -> int:
        if name not in self._len:
            self._len[name] = int(self.group[name].chunks[0])
        return self._len[name]
