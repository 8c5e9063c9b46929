"""The commit protocol of stores on object storage (``s3://``): no rename, no flock, the same promises.

A local store is built under ``<out>.partial``, guarded by ``flock`` and renamed into place (:mod:`storage.local`).
An object store has neither rename (a copy of every object) nor locks, so the store is written in place and its
state is told by objects:

1. **Lock**: ``<name>.zarr.lock`` beside the store, created with a conditional put (``If-None-Match: *``): of
   two writers exactly one creates it; the other is refused with one line. The lock names its host, pid and a
   token; the holder rewrites it every ``ttl/4`` seconds (:data:`LOCK_TTL_ENV`, default 120 s). A lock is stale,
   and taken over, when its process is dead on this host (a ``kill -9``: the rerun resumes at once) or when it
   was not refreshed for ``ttl`` seconds (a writer on another machine that died).
   AWS S3 (since 2024-08), MinIO, Ceph RGW and moto honour ``If-None-Match: *`` on PutObject. A backend that
   ignores the header makes both puts succeed: the second writer then reads the lock back, finds another token
   only if the first put landed after its own, and is refused then; two exactly simultaneous writers on such a
   backend are not told apart (their chunks are still the same bytes: every chunk is a pure function of its id).
2. **Creation**: the group, every array, then the group's svgen attributes (``complete: false``), the last write.
   A prefix whose group has no svgen attributes is a creation cut short and is recreated.
3. **Chunks**: a worker writes its chunk objects (each PUT is atomic), reads them back to hash them and then puts
   the marker ``.done/<chunk>`` holding the chunk's manifest record; a marker exists only after its chunk.
4. **Finalize**: consolidated metadata (still ``complete: false``), the manifest ``svgen_manifest.json``, then
   ``complete: true`` in one write of the group's ``zarr.json`` (the store's commit point), then the markers and the
   lock are deleted. Readers refuse a store whose ``complete`` is not true with one line; a rerun resumes it.

A killed run leaves the lock (stale), the markers of the chunks it finished and maybe chunk objects without a
marker: the rerun rewrites exactly the chunks without a marker, with the same bytes, and finalizes.
"""
from __future__ import annotations

import json
import os
import socket
import threading
import time
import uuid
import warnings

import numpy as np
import zarr

from svcore.errors import StoreError
from svcore.log import get_logger

from . import local as S
from .objstore import ObjectLocation, record_of, s3_errors

log = get_logger(__name__)

LOCK_SUFFIX = ".lock"

# markers live inside the store until it is complete; consolidation, which runs before, skips them knowingly
warnings.filterwarnings("ignore", message="Object at .done is not recognized", category=UserWarning)
LOCK_TTL_ENV = "SVGEN_LOCK_TTL"


def lock_ttl() -> float:
    return float(os.environ.get(LOCK_TTL_ENV, "120"))


class ObjectStoreWriter(S.StoreWriter):
    """:class:`storage.local.StoreWriter` for an ``s3://`` store (made by ``storage.store.open_writer(url, ...)``).

    ``final`` and ``partial`` are both the store's URL: the store is written in place and is incomplete until its
    ``complete`` attribute says otherwise.
    """

    def __init__(self, path, kind: str, n: int, chunk: int, arrays: dict[str, S.ArraySpec], config: dict,
                 attrs: dict | None = None, inputs=(), code_of: str = S.WRITER_CODE):
        self.loc = ObjectLocation(str(path))
        self.final = self.partial = self.loc.url
        self.lockkey = self.loc.sibling(LOCK_SUFFIX)
        self.kind, self.n, self.chunk = kind, int(n), int(chunk)
        self.arrays, self.config, self.hash = arrays, config, S.config_hash(config)
        self.attrs = attrs or {}
        self.code_of = code_of
        self._token: str | None = None
        self._beat: threading.Thread | None = None
        self._stop = threading.Event()
        if n <= 0:
            raise StoreError(f"nothing to write: {kind} store with {n} samples")
        S.refuse_inside(self.final, inputs)
        from .bounds import check_store_size

        self.task_bytes = check_store_size(self.final, self.n, self.chunk, arrays)

    # -- lifecycle -------------------------------------------------------------------------------
    def __enter__(self) -> "ObjectStoreWriter":
        self.loc.check_bucket("write")
        with s3_errors(self.final, "write"):
            self._lock()
            try:
                meta = self._meta()
                if isinstance(meta, dict) and meta.get("complete"):
                    raise StoreError(f"output {self.final} already exists; choose another path or delete it")
                if self._started(meta):
                    self._check_resumable(meta)
                    S.append_history(zarr.open_group(self.loc.zarr_store(read_only=False), mode="r+"), self.final)
                else:
                    self._create()
            except BaseException:
                self._unlock()
                raise
        return self

    def __exit__(self, exc_type=None, *exc) -> None:
        if self._token is None:
            return
        try:
            if exc_type is not None and self.done_samples() == 0:
                self.loc.delete_tree()  # failed before any chunk: nothing to resume, leave nothing behind
        except Exception:  # noqa: BLE001 - the store may be unreachable now; the lock still goes below if it can
            pass
        self._unlock()

    def _meta(self):
        raw = self.loc.read_or_none("zarr.json")
        if raw is None:
            return None
        try:
            return json.loads(raw).get("attributes", {}).get("svgen")
        except (ValueError, AttributeError):
            raise StoreError(f"{self.final} holds a zarr.json that is not JSON; delete the prefix to start over") \
                from None

    def _started(self, meta=None) -> bool:
        if isinstance(meta, dict):
            return True
        if self.loc.sizes(S.DONE_DIR):
            raise StoreError(f"{self.final} has written chunks but no svgen attributes; delete it to start over")
        return False  # nothing, or a creation cut short (group without attributes): recreate

    def _check_resumable(self, meta=None) -> None:
        if meta.get("kind") != self.kind or meta.get("config_hash") != self.hash:
            raise StoreError(f"{self.final} was started with a different configuration; rerun with the same options "
                             "to resume, or delete it to start over")

    def _create(self) -> None:
        st = self.loc.zarr_store(read_only=False)
        g = zarr.open_group(st, mode="w", zarr_format=3)  # clears the prefix (a creation cut short)
        S.create_arrays(g, self.arrays, self.n, self.chunk)
        S._kill_hook("create")
        # the svgen attributes last: until they exist the prefix is a creation cut short, recreated by a rerun
        g.attrs.update(S.creation_attrs(self.kind, self.hash, self.n, self.chunk, self.arrays, self.config,
                                        self.attrs, self.code_of, self.final))

    # -- the lock --------------------------------------------------------------------------------
    def _lock(self) -> None:
        token = uuid.uuid4().hex
        body = json.dumps({"host": socket.gethostname(), "pid": os.getpid(), "token": token}).encode()
        if not self.loc.create_exclusive(self.lockkey, body):
            holder = self._stale_lock()
            if holder is not None:
                raise StoreError(f"another run is writing {self.final} (lock object s3://{self.lockkey} held by "
                                 f"{holder}); if that run is dead, the lock expires {lock_ttl():.0f} s after its "
                                 f"last refresh ({LOCK_TTL_ENV})")
            log.warning("taking over the stale lock s3://%s", self.lockkey)
            self.loc.delete(self.lockkey)
            if not self.loc.create_exclusive(self.lockkey, body):
                raise StoreError(f"another run is writing {self.final} (it took the stale lock s3://{self.lockkey} "
                                 "at the same moment)")
        # a backend that ignores If-None-Match lets a second put overwrite the first: read it back
        got = self.loc.fs.cat_file(self.lockkey)
        if json.loads(got).get("token") != token:
            raise StoreError(f"another run is writing {self.final} (lock object s3://{self.lockkey})")
        self._token = token
        self._stop.clear()
        self._beat = threading.Thread(target=self._heartbeat, args=(body,), daemon=True)
        self._beat.start()

    def _stale_lock(self) -> str | None:
        """None where the existing lock is stale, else who holds it (for the message)."""
        try:
            info = self.loc.fs.info(self.lockkey, refresh=True)
            holder = json.loads(self.loc.fs.cat_file(self.lockkey))
        except FileNotFoundError:
            return None  # released meanwhile
        except ValueError:
            holder = {}
        who = f"pid {holder.get('pid')} on {holder.get('host')}"
        if holder.get("host") == socket.gethostname() and isinstance(holder.get("pid"), int):
            try:
                os.kill(holder["pid"], 0)
            except ProcessLookupError:
                return None  # killed on this machine
            except PermissionError:
                pass
        modified = info.get("LastModified")
        if modified is not None and time.time() - modified.timestamp() > lock_ttl():
            return None
        return who

    def _heartbeat(self, body: bytes) -> None:
        while not self._stop.wait(lock_ttl() / 4):
            try:
                fs = self.loc.fs
                if json.loads(fs.cat_file(self.lockkey)).get("token") != self._token:
                    return  # taken over: ours is gone
                fs.pipe_file(self.lockkey, body)
            except Exception:  # noqa: BLE001 - a missed refresh only shortens the lease
                pass

    def _unlock(self) -> None:
        self._stop.set()
        if self._token is not None:
            try:
                if json.loads(self.loc.fs.cat_file(self.lockkey)).get("token") == self._token:
                    self.loc.delete(self.lockkey)
            except Exception:  # noqa: BLE001 - the lock then goes stale by its TTL
                pass
        self._token = None

    # -- chunks ----------------------------------------------------------------------------------
    def _records(self) -> dict[int, bytes]:
        done = self.loc.sizes(S.DONE_DIR)
        return {int(k.rsplit("/", 1)[-1]): k for k in done if k.rsplit("/", 1)[-1].isdigit()}

    def pending(self) -> list[int]:
        with s3_errors(self.final, "list"):
            done = self._records()
        return [c for c in range(self.n_chunks) if c not in done]

    def finalize(self, attrs: dict | None = None) -> str:
        """Manifest, then ``complete: true`` as the one last write of the group; then markers and lock go."""
        with s3_errors(self.final, "finalize"):
            missing = self.pending()
            if missing:
                raise StoreError(f"cannot finalize {self.final}: chunks {missing[:5]}... are not written")
            manifest = {"algorithm": "sha256/128", "n": self.n, "chunk": self.chunk,
                        "arrays": {name: [None] * self.n_chunks for name in self.arrays}}
            for c, key in sorted(self._records().items()):
                rec = json.loads(self.loc.read(key))
                for name in self.arrays:
                    manifest["arrays"][name][c] = rec[name]
            st = self.loc.zarr_store(read_only=False)
            meta = dict(zarr.open_group(st, mode="r").attrs)
            meta.update(attrs or {})
            meta["svgen"] = {**meta["svgen"], "complete": False, "manifest": S.MANIFEST,
                             "schema_version": S.finished_schema(meta["svgen"])}
            from .labels import write_labels

            g = zarr.open_group(st, mode="r+")
            for name in write_labels(g, meta, self.chunk, S._compressors()):  # derived: hashed here, no marker
                manifest["arrays"][name] = [record_of(self.loc.read_or_none(f"{name}/{S._chunk_key(g[name], c)}"))
                                            for c in range(self.n_chunks)]
            g.attrs.put(meta)
            zarr.consolidate_metadata(st)
            self.loc.write(S.MANIFEST, json.dumps(manifest, sort_keys=True, separators=(",", ":")).encode())
            meta["svgen"]["complete"] = True
            # opened with its consolidated metadata, the group rewrites zarr.json with it: one put commits the store
            zarr.open_group(st, mode="r+", use_consolidated=True).attrs.put(meta)
            for key in self._records().values():
                self.loc.delete(self.loc.key(key))
        self._unlock()
        return self.final


def write_chunk_object(url: str, c: int, start: int, data: dict[str, np.ndarray]) -> None:
    """:func:`storage.store.write_chunk` on an object store (in a worker, on any machine)."""
    loc = ObjectLocation(url)
    with s3_errors(loc.url, "write a chunk of"):
        g = zarr.open_group(loc.zarr_store(read_only=False), mode="r+")
        for name, arr in data.items():
            g[name][start:start + len(arr)] = arr
        record = {name: record_of(loc.read_or_none(f"{name}/{S._chunk_key(g[name], c)}")) for name in data}
        loc.write(f"{S.DONE_DIR}/{c}", json.dumps(record, sort_keys=True).encode())
    S._pause_hook()
    S._kill_hook("chunk")


def _incomplete(url: str) -> str:
    return (f"{url} is incomplete (a run writing it was interrupted or is still running); rerun its command to "
            "resume")


def open_object_store(url: str, kinds: tuple[str, ...]) -> zarr.Group:
    """:func:`storage.store.open_store` for ``s3://``: the same checks, chunks read through a local cache.

    Raises:
        StoreError: missing bucket or store, unreachable endpoint, denied access, incomplete, foreign, damaged.
    """
    loc = ObjectLocation(url)
    with s3_errors(loc.url, "read"):
        sizes = loc.sizes()
        if not sizes:
            loc.check_bucket("read")
            raise StoreError(f"no store at {loc.url}: it does not exist")
        if "zarr.json" not in sizes:
            raise StoreError(f"{loc.url} is not a zarr v3 store (expected a {' or '.join(kinds)} store)")
        try:
            head = json.loads(loc.read("zarr.json"))
            meta = head.get("attributes", {}).get("svgen")
        except (ValueError, AttributeError) as e:
            raise StoreError(f"{loc.url} cannot be opened as a zarr v3 store: {S._one_line(e)}") from None
        if isinstance(meta, dict) and not meta.get("complete"):
            raise StoreError(_incomplete(loc.url))
        man_raw = loc.read_or_none(S.MANIFEST)
        try:
            g = zarr.open_consolidated(loc.zarr_store(read_only=True, cached=True,
                                                      cache_tag=record_of(man_raw or b"")[1]),
                                       mode="r", zarr_format=3)
        except Exception as e:  # noqa: BLE001
            raise StoreError(f"{loc.url} cannot be opened as a zarr v3 store: {S._one_line(e)}") from None
        S.check_meta(loc.url, g, meta, kinds, _incomplete(loc.url))
        if meta.get("schema_version", 0) < 2 or man_raw is None:
            raise StoreError(f"{loc.url} has no chunk manifest, so missing chunks cannot be detected; re-create it")
        man = json.loads(man_raw)
        S.compare_sizes(loc.url, g, man, lambda name, key: sizes.get(f"{name}/{key}"))
    return g


def verify_object_store(url: str, g: zarr.Group) -> int:
    """:func:`storage.store.verify_store` for ``s3://``: re-hash every chunk object (read from the bucket)."""
    loc = ObjectLocation(url)
    with s3_errors(loc.url, "verify"):
        man = json.loads(loc.read(S.MANIFEST))
        n, chunk, checked = int(man["n"]), int(man["chunk"]), 0
        for name, recs in man["arrays"].items():
            for c, rec in enumerate(recs):
                if rec is not None:
                    if record_of(loc.read_or_none(f"{name}/{S._chunk_key(g[name], c)}")) != rec:
                        raise StoreError(f"{loc.url}: array {name!r} chunk {c} (samples {c * chunk}:"
                                         f"{min(n, (c + 1) * chunk)}) does not match its checksum; the store is "
                                         "damaged: re-create or restore it")
                    checked += 1
    return checked
