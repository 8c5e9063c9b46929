"""String label arrays beside the index arrays, so that a plain ``xr.open_zarr`` shows names, not integers.

``preset`` ``(sample, parent)`` and ``category`` ``(sample,)`` store integer indices into the group attributes
``presets`` and ``categories`` (small fixed-size chunks that every reader, training included, reads). xarray cannot
follow an index into an attribute list, so :meth:`StoreWriter.finalize` also writes ``preset_name`` and
``category_name``: the same indices resolved to their names (``""`` where the index is -1), a zarr v3 ``string``
array (the type zarr-python and xarray write for ``str``; variable-length UTF-8, ``vlen-utf8`` codec) with the
same dimension names and one shard per task like every array, listed in the manifest, and named by the index
array's CF ``coordinates`` attribute, so that xarray makes them coordinates: ``ds.sel(sample=ds.preset_name[:, 0]
== "wood/oak_planks")`` works without svgen.

They are derived data, written once at finalize from the finished index arrays and the group attributes (which may
be completed only then); svgen's own readers keep reading the indices. Stores finished before them (no
``*_name`` arrays) are read as before: the arrays are additive, so the schema version does not change.
"""
from __future__ import annotations

import numpy as np
import zarr

#: index array -> the group attribute that lists its names
LABELS = {"preset": "presets", "category": "categories"}


def label_array(index: str) -> str:
    """The name of the string array of the index array ``index`` (``preset`` -> ``preset_name``)."""
    return f"{index}_name"


def names_of(index: np.ndarray, names: list[str]) -> np.ndarray:
    """Indices resolved to names, ``""`` where an index is -1.

    Args:
        index: integer indices of any shape, in ``[-1, len(names))``.
        names: the labels.

    Returns:
        str array of ``index``'s shape.
    """
    table = np.array([*names, ""], dtype=object)  # -1 picks the ""
    return table[np.asarray(index, dtype=np.int64)].astype(str)


def write_labels(g: zarr.Group, meta: dict, chunk: int, compressors) -> list[str]:
    """Create and fill the label array of every index array of ``g`` (at finalize, before consolidation).

    Args:
        g: the store's group, writable, every chunk of its index arrays written.
        meta: the group attributes the store is finished with (``presets``/``categories``).
        chunk: samples per task: each label array has one shard per task, as every array of the store.
        compressors: the store's compressors.

    Returns:
        the names of the arrays written (their chunk records go into the manifest).
    """
    written = []
    for index, key in LABELS.items():
        if index not in g:
            continue
        idx = g[index]
        name = label_array(index)
        dims = tuple(idx.metadata.dimension_names)
        per = (chunk, *idx.shape[1:])
        arr = g.create_array(name, shape=idx.shape, chunks=per, shards=per, dtype=str, fill_value="",
                             compressors=compressors, dimension_names=dims, overwrite=True,
                             attributes={"long_name": f"{idx.attrs.get('long_name', index)} (name)",
                                         "comment": f"the names of {index!r}: group attribute {key!r} at its "
                                                    "indices; '' where the index is -1"})
        arr[...] = names_of(idx[...], list(meta.get(key) or []))
        # CF: the index variable names its auxiliary coordinate, which xarray's decode_coords makes a coordinate
        idx.attrs["coordinates"] = name
        written.append(name)
    return written
