"""The door to a store, local or ``s3://``: every stage, reader and command opens, writes and checks stores here.

The store format and its local writer and reader live in :mod:`storage.local`, the commit protocol of object
storage in :mod:`storage.store_object` (which builds on the local module's format); this module picks one of
the two by the path, so neither backend knows the other. The names of :mod:`storage.local` that stages use
(``ArraySpec``, ``read_region``, ``refuse_inside``, the marker and manifest names, ...) are re-exported here so
that callers need one import.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import zarr

from . import local
from .card import CARD, render_card
from .local import (_ALL_KINDS, CREATING_SUFFIX, DONE_DIR, LOCK_SUFFIX, MANIFEST, PARTIAL_SUFFIX,  # noqa: F401
                    SAMPLE_DIM, SCHEMA_VERSION, SMALL_SAMPLE_BYTES, ArraySpec, ChunkCache, StoreWriter,
                    array_layout, check_chunks, config_hash, inside, partial_path, read_region, recorded_path,
                    refuse_inside, side_read, side_remove, side_write)
from .objstore import is_object_url
from .store_object import ObjectStoreWriter, open_object_store, verify_object_store, write_chunk_object


def open_writer(path, kind: str, n: int, chunk: int, arrays: dict[str, ArraySpec], config: dict,
                attrs: dict | None = None, inputs=(), code_of: str = local.WRITER_CODE) -> StoreWriter:
    """The writer of the store at ``path`` (use as a context manager): :class:`storage.local.StoreWriter` for a
    local path, :class:`storage.store_object.ObjectStoreWriter` for an ``s3://`` URL. Arguments: see
    :class:`storage.local.StoreWriter`."""
    cls = ObjectStoreWriter if is_object_url(path) else StoreWriter
    return cls(path, kind, n, chunk, arrays, config, attrs, inputs=inputs, code_of=code_of)


def write_chunk(partial: str | os.PathLike, c: int, start: int, data: dict[str, np.ndarray]) -> None:
    """Write one whole chunk (called in workers) and then its completion marker (:func:`storage.local.write_chunk`;
    ``s3://``: :func:`storage.store_object.write_chunk_object`)."""
    if is_object_url(partial):
        write_chunk_object(str(partial), c, start, data)
        local._kill_hook("chunk")
        return
    local.write_chunk(partial, c, start, data)


def open_store(path: str | os.PathLike, kind: str | tuple[str, ...]) -> zarr.Group:
    """Open a complete svgen store of the given kind(s) read-only.

    Raises:
        StoreError: missing, still partial, foreign, of another kind, newer schema, or incomplete.
    """
    if is_object_url(path):
        return open_object_store(str(path), (kind,) if isinstance(kind, str) else tuple(kind))
    return local.open_store(path, kind)


def verify_store(path: str | os.PathLike) -> int:
    """Full verification: re-hash every chunk file of a complete store against its manifest.

    Returns:
        the number of chunk files checked.

    Raises:
        StoreError: the first chunk whose bytes differ, naming the array and the samples.
    """
    if is_object_url(path):
        return verify_object_store(str(path), open_store(path, _ALL_KINDS))
    return local.verify_store(path)


def card_text(path) -> str:
    """The dataset card (:mod:`storage.card`) of a complete store at ``path`` (any kind).

    Raises:
        StoreError: missing, incomplete or not an svgen store.
    """
    return render_card(open_store(path, _ALL_KINDS))


def write_card(path) -> Path:
    """(Re)write the card of a complete store; returns its path."""
    text = card_text(path)
    dst = Path(path) / CARD
    tmp = dst.with_suffix(".md.tmp")
    tmp.write_text(text)
    tmp.replace(dst)
    return dst
