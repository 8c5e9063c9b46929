"""zarr v3 stores that never look complete before they are: the store format and its local-filesystem writer
and reader (``s3://`` stores: :mod:`storage.store_object`; the door for both: :mod:`storage.store`).

Life of a store written by a stage:

1. :class:`StoreWriter` creates ``<out>.partial/`` (a zarr v3 group), takes an
   exclusive ``flock`` on ``<out>.lock`` beside it (a second run on the same
   output is refused; the kernel drops the lock when a run is SIGKILLed), and
   creates every array up front: one shard per task along the sample axis (:func:`array_layout`). Below, a
   "chunk" of the store is that object, the unit of a task, a marker and a manifest record.
2. Workers write whole chunks with :func:`write_chunk` (aligned regions of the
   ``zarr.Array``, never ``da.to_zarr``: DESIGN.md) and then drop a marker file
   ``.done/<chunk>``; a marker exists only after its chunk's bytes are on disk.
3. :meth:`StoreWriter.finalize` checks every marker, writes the chunk manifest
   (``svgen_manifest.json``: per array and chunk, the chunk file's size and SHA-256, or null where zarr wrote
   no file because the chunk is all fill value), writes ``complete: true``, consolidates metadata, writes the
   dataset card ``README.md`` (:mod:`storage.card`) and renames ``.partial`` into place.

Every array has ``dimension_names`` (``sample`` first) and its own CF attributes (:class:`ArraySpec`), so
``xarray.open_zarr`` opens any store and decodes the maps' codes by their ``scale_factor``/``add_offset``.

Creation is atomic: the group, its arrays and attributes are built in ``<out>.partial.creating`` and renamed to
``<out>.partial`` only when whole, so a ``.partial`` is always resumable; a leftover ``.creating`` (or a
``.partial`` left half-created by an older svgen: no svgen attributes, no chunk written) is recreated.

A rerun after a kill finds the ``.partial`` store, checks that it was started
by the same configuration (a hash of it) and writes only the chunks without a
marker.

What is verified when (see :func:`check_chunks`, :func:`verify_store`):

* every open (:func:`open_store`, i.e. every reader: render, blend, export, fit, eval): the manifest is read
  and every chunk file is ``stat``-ed: a missing chunk, a chunk file the manifest does not list, or one whose
  size changed is refused, naming the array and the samples. zarr would read a missing chunk as zeros.
* every read: zarr's CRC32C codec checks the bytes of each chunk it decodes (:func:`read_region` names it).
* on request: :func:`verify_store` re-hashes every chunk file against the manifest's SHA-256.

Schema 2 stores (unsharded: one plain chunk per task, zstd 5) stay readable, by every reader: zarr decodes
each array by its own metadata and their manifests list one object per task too. Stores written before
manifests (schema 1) are refused with a line that says to re-create them: without a
manifest a missing chunk cannot be told from an all-fill-value chunk that zarr never writes.
"""
from __future__ import annotations

import fcntl
import hashlib
import json
import os
import re
import shutil
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import zarr
from zarr.codecs import Crc32cCodec, ZstdCodec

from svcore.errors import StoreError
from svcore.history import OUT, appended, history_line
from svcore.versions import store_versions

from .card import DATA_LICENSE
from .objstore import is_object_url, local_path, normalize_url

#: 2: chunk manifest (svgen_manifest.json) written at finalize; 3: the sharded layout (:func:`array_layout`); 4: new
#: render bytes, version 3's layout (#42: a point flash rendered by the plane's own intersection, no shadow ray; about
#: 2 8-bit codes per million differ from version 3's ``direct``). Readers read 2 to 4: the layout lives in each
#: array's zarr.json, the manifest lists one object per task either way, and a version-3 renders store's images
#: still agree with its own maps (docs/DATA.md); 5: the recipe blends store (no maps: the parents, weights and mask
#: seeds, mixed on read, storage/recipe.py), `svgen blend`'s default. Only a recipe store is written as version 5:
#: every other store's format is version 4's, and it records 4, so an older svgen still reads it. Readers read 2 to
#: 5 (a blends store with maps, of any version, is read as it always was); 6: the renders store without maps (its
#: readers read each SVBRDF's base maps from the input stores it records, storage/renders_inputs.py), written with
#: ``render.maps: inputs`` (the paper preset's); a renders store with maps is still written as version 4. Readers
#: read 2 to 6. A newer version is refused in one line.
SCHEMA_VERSION = 6
#: the version of the recipe blends store (the format version 5 made)
RECIPE_SCHEMA = 5
#: the version a store whose format did not change in versions 5 and 6 is written as (:func:`written_schema`)
UNCHANGED_SCHEMA = 4
#: per-sample arrays smaller than this get one inner chunk per shard (see :func:`array_layout`)
SMALL_SAMPLE_BYTES = 4096
MANIFEST = "svgen_manifest.json"
CREATING_SUFFIX = ".creating"
from .objstore import PARTIAL_SUFFIX, partial_path  # noqa: E402,F401 (defined below the backends: bounds uses them)
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
        dims: names of the per-sample axes, one per entry of ``shape`` (the store prepends ``sample``): the zarr
            ``dimension_names`` that let xarray open the store. Arrays of one store that share a name share its
            length. Empty: ``<array>_<axis>``.
        attrs: the array's own attributes, in CF conventions (``long_name``, ``units``, ``scale_factor`` /
            ``add_offset`` where the stored integers are a linear encoding, ``transfer_function`` where they are
            not): what xarray, or any reader without svgen, decodes and shows.
    """

    shape: tuple[int, ...]
    dtype: str
    encoding: str = ""
    space: str = "n/a"
    dims: tuple[str, ...] = ()
    attrs: dict = field(default_factory=dict, compare=False, hash=False)
    #: the zstd level its chunks are written with (the stores record it in their metadata, so any level reads alike)
    zstd_level: int = 1

    def dimension_names(self, name: str) -> tuple[str, ...]:
        """("sample", per-sample axis names) of this array stored as ``name``."""
        dims = self.dims or tuple(f"{name}_{i}" for i in range(len(self.shape)))
        if len(dims) != len(self.shape):
            raise ValueError(f"array {name!r}: {len(dims)} dimension names for shape {self.shape}")
        return (SAMPLE_DIM, *dims)

    def array_attrs(self) -> dict:
        """The per-array attributes written to its zarr.json (CF attributes, the encoding and the space)."""
        out = dict(self.attrs)
        if self.encoding:
            out.setdefault("encoding", self.encoding)
        if self.space != "n/a":
            out.setdefault("colour_space", self.space)
        return out


#: the name of the sample axis (axis 0) of every array of every store.
SAMPLE_DIM = "sample"


def config_hash(config: dict) -> str:
    """Stable hash of a JSON-able configuration (used to match a resumed run to its partial store)."""
    return hashlib.sha256(json.dumps(config, sort_keys=True, default=str).encode()).hexdigest()[:16]


#: the module whose code a store made by a writer used on its own (benchmarks, tests) records: the writer's.
WRITER_CODE = __name__


def _store_versions(code_of: str) -> dict[str, str]:
    """The versions a store records (:func:`svcore.versions.store_versions`): the libraries', and the digest of the
    source that module ``code_of`` (the stage's) can run; never the package version, which names the commit, so
    that every checkout of the same code writes the same bytes."""
    return store_versions(code_of)


def inside(path: str | os.PathLike, other: str | os.PathLike) -> bool:
    """Whether ``path`` is ``other`` or lies under it (both resolved, so spelling and symlinks do not matter;
    an object-store URL is inside another only by its key prefix, never inside a local path)."""
    if is_object_url(path) or is_object_url(other):
        if not (is_object_url(path) and is_object_url(other)):
            return False
        a, b = normalize_url(str(path)), normalize_url(str(other))
        return a == b or a.startswith(b + "/")
    a, b = Path(local_path(path)).resolve(), Path(local_path(other)).resolve()
    return a == b or b in a.parents


def refuse_inside(out: str | os.PathLike, inputs) -> None:
    """Refuse an output that is an input, lies inside one, or contains one: no command may modify its input.

    Raises:
        StoreError: naming the output and the input.
    """
    if inputs is None:
        return
    for i in ([inputs] if isinstance(inputs, (str, bytes)) or hasattr(inputs, "__fspath__") else list(inputs)):
        if i is None:
            continue
        for o in ((out,) if is_object_url(out) else (Path(local_path(out)), partial_path(out))):
            if inside(o, i) or inside(i, o):
                raise StoreError(f"output {out} lies inside input {i} (or contains it): a command never writes into "
                                 "its input; choose an output outside it")


def recorded_path(path: str | os.PathLike, out: str | os.PathLike) -> str:
    """How a store records an input path: relative to the output's directory, resolved first, so the absolute and
    the relative spellings of one input record the same string (and a store moved with its inputs stays valid).
    An object-store input is recorded as its URL; a local input of an object-store output as its resolved path."""
    if is_object_url(path):
        return normalize_url(str(path))
    if is_object_url(out):
        return str(Path(local_path(path)).resolve())
    return os.path.relpath(Path(local_path(path)).resolve(), Path(local_path(out)).resolve().parent)


def history_path(path: str | os.PathLike, out: str | os.PathLike) -> str:
    """How a store's CF history names a path given to the command that writes it (:mod:`svcore.history`):
    :data:`svcore.history.OUT` for the store itself, any other path as the store records an input
    (:func:`recorded_path`), so neither the working directory nor the spelling changes a byte."""
    rec = recorded_path(path, out)
    return OUT if rec == recorded_path(out, out) else rec


def _history_line(out: str | os.PathLike) -> str:
    """The line the running command adds to the history of the store at ``out``."""
    return history_line(lambda p: history_path(p, out))


def _compressors(level: int = 1):
    # zstd, in the zarr v3 spec so that xarray and any zarr reader open the stores (docs/CODECS.md: the measured
    # knee, delta + zstd 1, uses numcodecs.delta, outside the spec), at the array's level (ArraySpec.zstd_level: 1
    # for maps and labels, 3 for the renders' images; experiments/store_level_one); CRC32C: detects corrupted chunks.
    return [ZstdCodec(level=level), Crc32cCodec()]


def array_layout(spec: ArraySpec, n: int, chunk: int) -> dict:
    """The ``create_array`` arguments of one store array: its shape, dtype and layout (local and S3 stores alike).

    One shard per task: samples [c * chunk, (c + 1) * chunk) are one object, written whole by the one task that
    makes them (never two writers in one shard: DESIGN.md's sharded ``to_zarr`` corruption), so a store has one
    object per array per task (experiments/store_codecs/results/codecs.json: <= 200 per 10,000 views at 64 SVBRDFs
    per render task). Inside a shard, images and maps are chunked by one sample, so a random read decodes one sample; a
    per-sample array under :data:`SMALL_SAMPLE_BYTES` (ids, seeds, view parameters) is one inner chunk per shard,
    because readers read those whole and a chunk per sample would cost more index and checksum than data.

    Args:
        spec: the array's per-sample spec.
        n: samples of the store.
        chunk: samples per task (the shard length along the sample axis).
    """
    per_sample = int(np.prod(spec.shape, dtype=np.int64)) * np.dtype(spec.dtype).itemsize
    inner = 1 if per_sample >= SMALL_SAMPLE_BYTES else chunk
    return {"shape": (n, *spec.shape), "chunks": (inner, *spec.shape), "shards": (chunk, *spec.shape),
            "dtype": spec.dtype, "compressors": _compressors(spec.zstd_level), "fill_value": 0}


def create_arrays(g: zarr.Group, arrays: dict[str, ArraySpec], n: int, chunk: int) -> None:
    """Create every array of a new store in ``g``: the one place that does, for local and ``s3://`` stores alike,
    so both carry the same layout, ``dimension_names`` and CF attributes (issue #28: S3 stores once had neither).

    Args:
        g: the new, empty group.
        arrays: name -> :class:`ArraySpec`.
        n: samples of the store.
        chunk: samples per task (the shard length).
    """
    for name, spec in arrays.items():
        g.create_array(name, **array_layout(spec, n, chunk), dimension_names=spec.dimension_names(name),
                       attributes=spec.array_attrs())


def creation_attrs(kind: str, hash_: str, n: int, chunk: int, arrays: dict[str, ArraySpec], config: dict,
                   attrs: dict, code_of: str, out: str | os.PathLike) -> dict:
    """The group attributes a new store at ``out`` is created with (``complete: false``), for both backends; its
    code is what module ``code_of`` can run (:func:`_store_versions`)."""
    versions = _store_versions(code_of)
    return {
        "svgen": {
            "kind": kind, "schema_version": written_schema(kind, arrays), "complete": False, "config_hash": hash_,
            "n": n, "chunk": chunk,
            "arrays": {k: {"shape": list(v.shape), "dtype": v.dtype, "encoding": v.encoding, "space": v.space}
                       for k, v in arrays.items()},
            "versions": versions,
        },
        "config": config,
        **attrs,
        # global CF attributes (xarray shows them; CF: the command that made it is `history`, svcore.history, and a
        # resume by another command line appends its own)
        "Conventions": "CF-1.11",
        "title": f"svgen {kind} store",
        "source": f"svgen ({versions['svgen']})",
        "license": DATA_LICENSE if "import" not in attrs else "each imported material's own (attribute 'materials')",
        "history": _history_line(out),
    }


def append_history(g: zarr.Group, out: str | os.PathLike) -> None:
    """Append the current command to the CF ``history`` of the partial store of ``out`` being resumed (unless the
    same command started it: :func:`svcore.history.appended`)."""
    g.attrs["history"] = appended(dict(g.attrs).get("history"), _history_line(out))


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
        inputs: the stores this run reads; an output inside one of them is refused.
        code_of: the module whose source (with what it imports) the store names as its code: the stage's.
    """

    def __init__(self, path, kind: str, n: int, chunk: int, arrays: dict[str, ArraySpec], config: dict,
                 attrs: dict | None = None, inputs=(), code_of: str = WRITER_CODE):
        if is_object_url(path):  # s3://…: the commit protocol without rename or flock (storage.store.open_writer)
            raise StoreError(f"{path}: an object-store URL; its writer is storage.store.open_writer's")
        self.final = Path(local_path(path))
        self.partial = partial_path(self.final)
        self.lockfile = self.final.with_name(self.final.name + LOCK_SUFFIX)
        self.kind, self.n, self.chunk = kind, int(n), int(chunk)
        self.arrays = arrays
        self.config = config
        self.hash = config_hash(config)
        self.attrs = attrs or {}
        self.code_of = code_of
        self._lock_fd: int | None = None
        if n <= 0:
            raise StoreError(f"nothing to write: {kind} store with {n} samples")
        refuse_inside(self.final, inputs)
        if self.final.exists():
            raise StoreError(f"output {self.final} already exists; choose another path or delete it")
        from .bounds import check_store_size

        #: estimated peak bytes of one chunk task (pass to run_chunks: it bounds the local workers by memory)
        self.task_bytes = check_store_size(self.final, self.n, self.chunk, arrays)

    @property
    def creating(self) -> Path:
        return self.partial.with_name(self.partial.name + CREATING_SUFFIX)

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
            if self._started():
                self._check_resumable()
                (self.partial / DONE_DIR).mkdir(exist_ok=True)
                append_history(zarr.open_group(self.partial, mode="r+"), self.final)
            else:
                self._create()
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
            shutil.rmtree(self.creating, ignore_errors=True)
            os.remove(self.lockfile)
        if self._lock_fd is not None:
            fcntl.flock(self._lock_fd, fcntl.LOCK_UN)
            os.close(self._lock_fd)
            self._lock_fd = None

    def _started(self) -> bool:
        """Whether ``.partial`` holds a fully created store (resumable) rather than nothing or a creation cut short.

        Raises:
            StoreError: a ``.partial`` without svgen attributes that nevertheless holds written chunks.
        """
        if not (self.partial / "zarr.json").exists():
            return False  # nothing, or an empty directory an older svgen made before creating the group
        try:
            meta = dict(zarr.open_group(self.partial, mode="r").attrs).get("svgen")
        except Exception as e:
            raise StoreError(f"{self.partial} exists but cannot be read ({_one_line(e)}); delete it to start over") \
                from None
        if isinstance(meta, dict):
            return True
        done = self.partial / DONE_DIR
        if done.exists() and any(done.iterdir()):
            raise StoreError(f"{self.partial} has written chunks but no svgen attributes; delete it to start over")
        return False  # an older svgen was killed between the group's zarr.json and its attributes: no work lost

    def _create(self) -> None:
        """Build the empty store under ``.partial.creating`` and rename it to ``.partial`` when whole (atomic)."""
        shutil.rmtree(self.creating, ignore_errors=True)  # a creation cut short by a kill
        g = zarr.open_group(self.creating, mode="w", zarr_format=3)
        create_arrays(g, self.arrays, self.n, self.chunk)
        g.attrs.update(creation_attrs(self.kind, self.hash, self.n, self.chunk, self.arrays, self.config, self.attrs,
                                      self.code_of, self.final))
        (self.creating / DONE_DIR).mkdir()
        _kill_hook("create")
        if self.partial.exists():  # a half-created partial of an older svgen (see _started): holds no chunk
            shutil.rmtree(self.partial)
        os.replace(self.creating, self.partial)

    def _check_resumable(self) -> None:
        try:
            meta = dict(zarr.open_group(self.partial, mode="r").attrs).get("svgen", {})
        except Exception as e:
            raise StoreError(f"{self.partial} exists but cannot be read ({_one_line(e)}); delete it to start over") \
                from None
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
        manifest = {"algorithm": "sha256/128", "n": self.n, "chunk": self.chunk,
                    "arrays": {name: [None] * self.n_chunks for name in self.arrays}}
        for c in range(self.n_chunks):
            rec = _chunk_record(self.partial, g, c, self.arrays, self.partial / DONE_DIR / str(c))
            for name in self.arrays:
                manifest["arrays"][name][c] = rec[name]
        meta = dict(g.attrs)
        meta.update(attrs or {})
        meta["svgen"] = {**meta["svgen"], "complete": True, "manifest": MANIFEST,
                         "schema_version": finished_schema(meta["svgen"])}
        now = _store_versions(self.code_of)["svgen"]
        if meta["svgen"].get("versions", {}).get("svgen") != now:  # resumed by other code than started it
            meta["svgen"]["versions"] = {**meta["svgen"].get("versions", {}), "svgen_finished_by": now}
        from .labels import write_labels

        for name in write_labels(g, meta, self.chunk, _compressors()):  # derived, so no marker: hashed here
            manifest["arrays"][name] = [_file_record(self.partial / name / _chunk_key(g[name], c))
                                        for c in range(self.n_chunks)]
        g.attrs.put(meta)
        shutil.rmtree(self.partial / DONE_DIR)
        # zarr's LocalStore writes each chunk to "<key>.<uuid hex>.partial" and renames it: a kill mid-write leaves
        # that file behind, and the resumed run rewrites the chunk under its real key. Drop the orphans so the
        # finished store holds exactly what a clean run writes (tests/test_dvc_pipeline.py, SIGKILL during render).
        for orphan in self.partial.rglob("*.partial"):
            if orphan.is_file() and ZARR_TMP.search(orphan.name):
                orphan.unlink()
        zarr.consolidate_metadata(self.partial)
        from .card import CARD, render_card

        # the dataset card, from the attributes just written (after consolidation, which would warn about a file
        # outside the zarr hierarchy); inside the partial store, so it appears with the finished store and not before
        (self.partial / CARD).write_text(render_card(zarr.open_consolidated(self.partial, mode="r", zarr_format=3)))
        # after consolidation, which would warn about a file that is not part of the zarr hierarchy
        (self.partial / MANIFEST).write_text(json.dumps(manifest, sort_keys=True, separators=(",", ":")))
        os.replace(self.partial, self.final)  # still under the lock: nobody else can have made final
        os.remove(self.lockfile)
        self.__exit__()
        return self.final


def written_schema(kind: str, arrays: dict) -> int:
    """The format version a new store of ``kind`` with ``arrays`` records: :data:`RECIPE_SCHEMA` for a recipe
    blends store (a blends store with no maps, the format version 5 made), :data:`SCHEMA_VERSION` for a renders
    store with no maps (version 6), :data:`UNCHANGED_SCHEMA` otherwise (an older svgen reads those)."""
    if "diffuse" in arrays or kind not in ("blends", "renders"):
        return UNCHANGED_SCHEMA
    return RECIPE_SCHEMA if kind == "blends" else SCHEMA_VERSION


def finished_schema(svgen: dict) -> int:
    """The schema a finished store records: the one its partial was created with (a partial an older svgen started
    keeps that svgen's unsharded layout: zarr writes by each array's own metadata), at least 2, since finalize
    writes the manifest (a schema 1 partial, with "ok" markers, gets it here)."""
    return max(2, int(svgen.get("schema_version", 1)))


def write_chunk(partial: str | os.PathLike, c: int, start: int, data: dict[str, np.ndarray]) -> None:
    """Write one whole chunk (called in workers) and then its completion marker.

    Args:
        partial: the ``.partial`` store directory.
        c: chunk id.
        start: first sample index of the chunk.
        data: array name -> (n_in_chunk, *sample_shape) values already in the on-disk dtype.
    """
    g = zarr.open_group(partial, mode="r+")
    written = {}
    for name, arr in data.items():
        a = g[name]
        parts = encode_shard_parts(a, c, start, arr)
        if parts is None:  # a layout or values the direct encoder does not take: zarr writes it
            a[start:start + len(arr)] = arr
        else:
            path = Path(partial) / name / _chunk_key(a, c)
            _atomic_write(path, parts)
            digest = hashlib.sha256()
            for part in parts:
                digest.update(part)
            written[name] = [sum(map(len, parts)), digest.hexdigest()[:32]]
    _fail_once_hook(c)
    # the marker is the chunk's record in the manifest-to-be: size and hash of each array's chunk file, hashed
    # here, once, by the worker that wrote it (from the bytes it wrote, where it encoded the shard itself)
    record = {name: written[name] if name in written else _file_record(Path(partial) / name / _chunk_key(g[name], c))
              for name in data}
    marker = Path(partial) / DONE_DIR / str(c)
    tmp = marker.with_suffix(".tmp")
    tmp.write_text(json.dumps(record, sort_keys=True))
    os.replace(tmp, marker)
    _pause_hook()
    _kill_hook("chunk")
    if os.environ.get("SVGEN_TEST_ENOSPC_AFTER_CHUNK") == str(c):  # a full disk where no small one can be mounted
        import errno

        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(Path(partial) / DONE_DIR))


#: the codecs :func:`encode_shard` writes itself: :func:`array_layout`'s (sharded, zstd without checksum, CRC32C,
#: little-endian bytes, index at the end). An array with any other metadata is written by zarr.
_INNER_CODECS = ({"name": "bytes", "configuration": {"endian": "little"}}, "zstd", {"name": "crc32c"})
_INDEX_CODECS = ({"name": "bytes", "configuration": {"endian": "little"}}, {"name": "crc32c"})
_ZSTD: dict = {}


def _crc32c(b) -> bytes:
    import google_crc32c

    return np.uint32(google_crc32c.value(b)).tobytes()


def encode_shard(arr: zarr.Array, c: int, start: int, values: np.ndarray) -> bytes | None:
    """The bytes zarr writes for shard ``c`` of ``arr`` holding ``values``, encoded here, or None where zarr must
    write it: :func:`encode_shard_parts`, joined."""
    parts = encode_shard_parts(arr, c, start, values)
    return None if parts is None else b"".join(parts)


def encode_shard_parts(arr: zarr.Array, c: int, start: int, values: np.ndarray) -> list[bytes] | None:
    """The bytes zarr writes for shard ``c`` of ``arr`` holding ``values``, encoded here, as the parts that make
    them in order (each inner chunk, its CRC32C, the index and its CRC32C: the writer writes them one after the other,
    with no joined copy of the shard, which at 288² is 90 MB of images per 64-SVBRDF task), or None where zarr must
    write it (any layout but :func:`array_layout`'s, a dtype zarr would cast, a region that is not the whole shard,
    or an inner chunk all fill value, which zarr leaves out of the shard).

    The same codec calls as zarr's sharding codec (numcodecs' Zstd at the array's level, CRC32C appended to each
    inner chunk, the uint64 (offset, length) index with its CRC32C at the end, inner chunks in order along the
    sample axis), without its per-chunk asyncio tasks, thread hand-offs and two whole-array fill-value scans, which
    cost about as much CPU as the compression itself (experiments/sample_rate/REPORT.md). Same bytes:
    tests/test_store_fast_write.py compares them with zarr's for every layout the stages write.
    """
    meta = arr.metadata
    try:
        (sharding,) = meta.to_dict()["codecs"]
        cfg = sharding["configuration"]
        inner_codecs = cfg["codecs"]
        # zarr writes a 1-byte dtype's "bytes" codec without an endian setting (the renders' uint8 image): the same
        # bytes, one per value, so it is taken only for such a dtype
        one_byte = np.dtype(arr.dtype).itemsize == 1 and inner_codecs[0] == {"name": "bytes"}
        if (sharding["name"] != "sharding_indexed" or str(cfg.get("index_location", "end")) != "end"
                or tuple(cfg["index_codecs"]) != _INDEX_CODECS or len(inner_codecs) != 3
                or (inner_codecs[0] != _INNER_CODECS[0] and not one_byte) or inner_codecs[2] != _INNER_CODECS[2]
                or inner_codecs[1]["name"] != "zstd" or inner_codecs[1]["configuration"].get("checksum", False)):
            return None
        level = int(inner_codecs[1]["configuration"]["level"])
        inner = tuple(cfg["chunk_shape"])
    except (KeyError, TypeError, ValueError, AttributeError):
        return None
    shard, shape = tuple(arr.shards or ()), tuple(arr.shape)
    sample = shape[1:]
    dtype = np.dtype(arr.dtype)
    if (not shard or shard[1:] != sample or inner[1:] != sample or inner[0] not in (1, shard[0])
            or shard[0] % inner[0] or meta.fill_value != 0 or dtype.byteorder == ">"
            or meta.to_dict().get("chunk_key_encoding") != {"name": "default", "configuration": {"separator": "/"}}):
        return None
    n_shard = shard[0]
    stop = min(shape[0], (c + 1) * n_shard)
    values = np.asarray(values)
    if start != c * n_shard or values.shape != (stop - start, *sample) or values.dtype != dtype:
        return None
    k = inner[0]
    if k == 1:  # one inner chunk per sample; the samples past the array's end are not in the shard (all fill)
        chunks = list(np.ascontiguousarray(values).reshape(len(values), -1))
    else:  # one inner chunk, the shard, padded with the fill value past the array's end
        full = np.zeros((n_shard, *sample), dtype)
        full[:len(values)] = values
        chunks = [full.reshape(-1)]
    if not all(bool(ch.any()) for ch in chunks):  # (NaN counts as set, -0.0 as fill: zarr's all_equal(0))
        return None
    zstd = _ZSTD.get(level)
    if zstd is None:
        from numcodecs import Zstd

        zstd = _ZSTD[level] = Zstd(level=level, checksum=False)
    index = np.full((n_shard // k, 2), np.iinfo(np.uint64).max, "<u8")
    parts, offset = [], 0
    for i, ch in enumerate(chunks):
        body = zstd.encode(ch.view(np.uint8))
        parts += [body, _crc32c(body)]
        index[i] = offset, len(body) + 4
        offset += len(body) + 4
    ib = index.tobytes()
    return parts + [ib, _crc32c(ib)]


def _atomic_write(path: Path, data: bytes | list[bytes]) -> None:
    """Write a chunk file as zarr's LocalStore does: a temporary ``.{uuid hex}.partial`` beside it (:data:`ZARR_TMP`),
    renamed into place. ``data``: its bytes, or the parts that make them, in order."""
    import uuid

    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".{uuid.uuid4().hex}.partial")
    try:
        with tmp.open("wb") as f:
            if isinstance(data, list):
                f.writelines(data)
            else:
                f.write(data)
        tmp.replace(path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def side_write(partial, rel: str, data: bytes) -> None:
    """Write a stage's own object ``rel`` (e.g. per-chunk records) into an unfinished store, atomically: a temporary
    file renamed into place locally, one PUT on an object store."""
    if is_object_url(partial):
        from .objstore import ObjectLocation, s3_errors

        loc = ObjectLocation(str(partial))
        with s3_errors(loc.url, "write"):
            loc.write(rel, data)
        return
    target = Path(partial) / rel
    target.parent.mkdir(exist_ok=True)
    tmp = target.with_suffix(".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, target)


def side_read(partial, rel: str) -> bytes:
    """Read a stage's own object written by :func:`side_write`."""
    if is_object_url(partial):
        from .objstore import ObjectLocation, s3_errors

        loc = ObjectLocation(str(partial))
        with s3_errors(loc.url, "read"):
            return loc.read(rel)
    return (Path(partial) / rel).read_bytes()


def side_remove(partial, rel_dir: str) -> None:
    """Remove a stage's own folder of objects (before finalize: it is not part of the finished store)."""
    if is_object_url(partial):
        from .objstore import ObjectLocation, s3_errors

        loc = ObjectLocation(str(partial))
        with s3_errors(loc.url, "clean"):
            for k in loc.sizes(rel_dir):
                loc.delete(loc.key(k))
        return
    shutil.rmtree(Path(partial) / rel_dir)


def _kill_hook(moment: str) -> None:
    """Tests kill a real run at a chosen moment: ``SVGEN_TEST_KILL_AT=create`` (the store is created, not yet
    renamed) or ``chunk`` (right after the first chunk's marker). Unset in normal use: does nothing.
    (``SVGEN_TEST_ENOSPC_AFTER_CHUNK=c`` makes the worker that wrote chunk c fail as a full disk does.)"""
    if os.environ.get("SVGEN_TEST_KILL_AT") == moment:
        import signal

        os.kill(os.getpid(), signal.SIGKILL)


def _pause_hook() -> None:
    """Tests act on a real run at a known moment (stop the S3 server under it): with
    ``SVGEN_TEST_PAUSE_DIR=<dir>``, the first chunk's writer, right after its marker, creates ``<dir>/paused`` and
    waits until ``<dir>/resume`` exists (at most 300 s); later chunks run on. Unset: does nothing."""
    d = os.environ.get("SVGEN_TEST_PAUSE_DIR")
    if not d or (Path(d) / "resume").exists() or (Path(d) / "paused").exists():
        return
    (Path(d) / "paused").touch()
    deadline = time.monotonic() + 300
    while not (Path(d) / "resume").exists() and time.monotonic() < deadline:
        time.sleep(0.02)


def _fail_once_hook(c: int) -> None:
    """Tests make every chunk task fail once, after its data and before its record (the retry must rewrite it):
    ``SVGEN_TEST_FAIL_ONCE_DIR=<dir>`` (a file per chunk there says it already failed). Unset: does nothing."""
    d = os.environ.get("SVGEN_TEST_FAIL_ONCE_DIR")
    if d and not (Path(d) / f"chunk{c}").exists():
        (Path(d) / f"chunk{c}").touch()
        raise ConnectionResetError(f"injected transient failure in chunk {c}")


def _one_line(e: object) -> str:
    return " ".join(str(e).split())


def _chunk_key(arr: zarr.Array, c: int) -> str:
    """Path of chunk ``c`` (along the sample axis) of ``arr`` relative to the array's directory."""
    return arr.metadata.encode_chunk_key((c,) + (0,) * (arr.ndim - 1))


def _file_record(path: Path) -> list | None:
    """[size, sha256 (128 bits, hex)] of a chunk file; None where zarr wrote none (the chunk is all fill value)."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    return [len(data), hashlib.sha256(data).hexdigest()[:32]]


def _chunk_record(partial: Path, g: zarr.Group, c: int, arrays, marker: Path) -> dict:
    """The manifest record of chunk ``c``: from its marker, or hashed now for a marker an older svgen wrote."""
    try:
        rec = json.loads(marker.read_text())
    except (ValueError, OSError):
        rec = {}
    if not isinstance(rec, dict) or set(rec) != set(arrays):
        rec = {name: _file_record(partial / name / _chunk_key(g[name], c)) for name in arrays}
    return rec


def open_store(path: str | os.PathLike, kind: str | tuple[str, ...]) -> zarr.Group:
    """Open a complete svgen store of the given kind(s) read-only.

    Raises:
        StoreError: missing, still partial, foreign, of another kind, newer schema, or incomplete.
    """
    kinds = (kind,) if isinstance(kind, str) else tuple(kind)
    p = Path(local_path(path))
    want = " or ".join(kinds)
    if p.name.endswith(PARTIAL_SUFFIX) or p.name.endswith(PARTIAL_SUFFIX + CREATING_SUFFIX):
        final = p.with_name(p.name[:p.name.rindex(PARTIAL_SUFFIX)])
        raise StoreError(f"{p} is an unfinished store (a run writing {final} is in progress or was interrupted); "
                         f"rerun its command to resume, then use {final}")
    if not p.exists():
        if partial_path(p).exists():
            raise StoreError(f"{p} is incomplete (an interrupted run left {partial_path(p)}); rerun its command to resume")
        raise StoreError(f"no store at {p}: it does not exist")
    if not (p / "zarr.json").exists():
        raise StoreError(f"{p} is not a zarr v3 store (expected a {want} store)")
    try:
        g = zarr.open_consolidated(p, mode="r", zarr_format=3)
        meta = dict(g.attrs).get("svgen")
    except Exception as e:
        raise StoreError(f"{p} cannot be opened as a zarr v3 store: {_one_line(e)}") from None
    check_meta(p, g, meta, kinds, f"{p} is not marked complete")
    check_chunks(p, g, meta)
    return g


def check_meta(p, g: zarr.Group, meta, kinds: tuple[str, ...], incomplete: str) -> None:
    """The checks of every open, local or object store: an svgen store of a wanted kind, a schema this svgen
    reads, marked complete (else the line ``incomplete``), every array present.

    Raises:
        StoreError: the first check that fails.
    """
    want = " or ".join(kinds)
    if not isinstance(meta, dict) or "kind" not in meta:
        raise StoreError(f"{p} is not an svgen store (no svgen attributes); expected a {want} store")
    if meta["kind"] not in kinds:
        raise StoreError(f"{p} is a {meta['kind']} store, expected a {want} store")
    if meta.get("schema_version", 0) > SCHEMA_VERSION:
        raise StoreError(f"{p} has schema version {meta['schema_version']}, newer than this svgen ({SCHEMA_VERSION})")
    if not meta.get("complete"):
        raise StoreError(incomplete)
    for name in meta.get("arrays", {}):
        if name not in g:
            raise StoreError(f"{p} lacks its array {name!r}")


def _manifest(p: Path, meta: dict) -> dict:
    if meta.get("schema_version", 0) < 2 or not (p / MANIFEST).exists():
        raise StoreError(f"{p} was written by an older svgen without a chunk manifest (schema "
                         f"{meta.get('schema_version', 0)}), so missing chunks cannot be detected; re-create it with "
                         "this svgen (rerun its command, or `dvc repro`)")
    try:
        return json.loads((p / MANIFEST).read_text())
    except (ValueError, OSError) as e:
        raise StoreError(f"{p}: its chunk manifest {MANIFEST} cannot be read ({_one_line(e)}); re-create the store") \
            from None


def check_chunks(path: str | os.PathLike, g: zarr.Group, meta: dict) -> None:
    """The cheap check of every open: each chunk the manifest lists exists with its size, and no other does.

    One ``stat`` per chunk file (no reading): zarr reads a missing chunk as its fill value (zeros), which would
    silently turn a damaged store into black maps or zero seeds.

    Raises:
        StoreError: naming the array, the chunk and its samples.
    """
    p = Path(path)
    man = _manifest(p, meta)
    stat = os.stat

    def size_of(name: str, key: str) -> int | None:
        try:
            return stat(f"{p}{os.sep}{name}{os.sep}{key}").st_size
        except FileNotFoundError:
            return None

    compare_sizes(p, g, man, size_of)


def compare_sizes(p, g: zarr.Group, man: dict, size_of) -> None:
    """Hold every chunk's size (``size_of(array, chunk key)``, None: no chunk object) to the manifest.

    Raises:
        StoreError: naming the array, the chunk and its samples.
    """
    n, chunk = int(man["n"]), int(man["chunk"])
    for name, recs in man["arrays"].items():
        arr = g[name]
        for c, rec in enumerate(recs):
            size = size_of(name, _chunk_key(arr, c))
            if (rec is None) != (size is None) or (rec is not None and rec[0] != size):
                a, b = c * chunk, min(n, (c + 1) * chunk)
                what = "is missing chunk" if size is None else \
                    "has a chunk the manifest does not list:" if rec is None else "has a changed chunk"
                raise StoreError(f"{p}: array {name!r} {what} {c} (samples {a}:{b}); the store is damaged: "
                                 "re-create it or restore it (dvc checkout)")


def verify_store(path: str | os.PathLike) -> int:
    """Full verification: re-hash every chunk file of a complete store against its manifest.

    Returns:
        the number of chunk files checked.

    Raises:
        StoreError: the first chunk whose bytes differ, naming the array and the samples.
    """
    g = open_store(path, tuple(_ALL_KINDS))
    p = Path(local_path(path))
    man = json.loads((p / MANIFEST).read_text())
    n, chunk, checked = int(man["n"]), int(man["chunk"]), 0
    for name, recs in man["arrays"].items():
        for c, rec in enumerate(recs):
            if rec is not None:
                if _file_record(p / name / _chunk_key(g[name], c)) != rec:
                    raise StoreError(f"{p}: array {name!r} chunk {c} (samples {c * chunk}:{min(n, (c + 1) * chunk)}) "
                                     "does not match its checksum; the store is damaged: re-create or restore it")
                checked += 1
    return checked


_ALL_KINDS = ("variants", "blends", "stress", "renders")


def read_region(g: zarr.Group, name: str, start: int, stop: int, arr: zarr.Array | None = None) -> np.ndarray:
    """Read samples [start, stop) of an array, naming the chunk if it is corrupt. ``arr``: ``g[name]`` already
    opened (each ``g[name]`` reads the array's metadata from the store again)."""
    try:
        return (g[name] if arr is None else arr)[start:stop]
    except Exception as e:
        arr = g[name]
        chunk = (arr.shards or arr.chunks)[0]  # the object: a shard (schema 3) or a chunk (schema 2)
        raise StoreError(f"corrupt data in {g.store} array {name!r}, samples {start}:{stop} "
                         f"(chunk {start // chunk}): {e}") from None


class ChunkCache:
    """Whole decoded chunks of a store's arrays, kept up to a byte budget (FIFO eviction).

    Random access by sample (blending random pairs, a training loader drawing random views) would otherwise
    decompress a whole chunk, and pay zarr's per-call overhead, for every single sample. The unit is zarr's chunk:
    in a sharded store (schema 3) the inner chunk, one sample of an image or map array (:func:`array_layout`).

    With ``whole_shards`` the unit is the shard (one task's samples): a reader that will touch most samples of a
    store (a blend stage with at least as many parent draws as variants) reads each shard once, where one read per
    sample costs about 2.5x the CPU per sample (zarr's per-call work and the shard index read again each time;
    experiments/sample_rate/REPORT.md).

    Args:
        group: an open store.
        budget_bytes: decoded bytes kept at most.
        whole_shards: read and keep whole shards, not inner chunks.
    """

    def __init__(self, group: zarr.Group, budget_bytes: int = 3 << 30, whole_shards: bool = False):
        self.group, self.budget, self.whole_shards = group, int(budget_bytes), bool(whole_shards)
        self._chunks: dict[tuple[str, int], np.ndarray] = {}
        self._bytes = 0
        self._len = {}
        self._arrays: dict[str, zarr.Array] = {}

    def chunk(self, name: str, c: int) -> np.ndarray:
        """Chunk ``c`` of array ``name`` along the sample axis (read once, then from memory)."""
        key = (name, c)
        if key not in self._chunks:
            n = self._chunk_len(name)
            a = read_region(self.group, name, c * n, (c + 1) * n, self._array(name))
            while self._chunks and self._bytes + a.nbytes > self.budget:
                self._bytes -= self._chunks.pop(next(iter(self._chunks))).nbytes
            self._chunks[key] = a
            self._bytes += a.nbytes
        return self._chunks[key]

    def resize(self, budget_bytes: int) -> None:
        """Keep at most ``budget_bytes`` from now on, evicting the oldest chunks that are over it."""
        self.budget = max(0, int(budget_bytes))
        while self._chunks and self._bytes > self.budget:
            self._bytes -= self._chunks.pop(next(iter(self._chunks))).nbytes

    def sample(self, name: str, i: int) -> np.ndarray:
        """Sample ``i`` of array ``name``."""
        n = self._chunk_len(name)
        return self.chunk(name, i // n)[i % n]

    def _array(self, name: str) -> zarr.Array:
        if name not in self._arrays:
            self._arrays[name] = self.group[name]
        return self._arrays[name]

    def _chunk_len(self, name: str) -> int:
        if name not in self._len:
            arr = self._array(name)
            self._len[name] = int(((self.whole_shards and arr.shards) or arr.chunks)[0])
        return self._len[name]
