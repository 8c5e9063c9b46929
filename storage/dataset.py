"""A store as an analysis-ready :class:`xarray.Dataset` (``storage.dataset.open_dataset``).

``xr.open_zarr(store)`` already opens every store (named dimensions, CF ``scale_factor``/``add_offset``, global CF
attributes); what xarray cannot take from the zarr metadata alone, this adds:

* ``preset`` and ``category`` become labelled string coordinates under their own names (the stored arrays are
  indices into the group's ``presets``/``categories`` lists, which every svgen reader reads; plain ``xr.open_zarr``
  shows the names as the coordinates ``preset_name``/``category_name`` of stores that have them,
  :mod:`storage.labels`, which this drops as duplicates);
* maps decode to float32: xarray picks the decoded type from the type of ``scale_factor``, and a JSON attribute
  is always a float64; 16-bit codes need no more than float32's 24 bits. The CF encoding (``dtype`` uint16,
  ``scale_factor``, ``add_offset``) stays in ``.encoding``, so writing the dataset stores the codes again;
* dask chunks of one shard (one task's samples) instead of zarr's inner chunks of one sample, which are sized for
  random reads by a training loop, not for reductions over the whole store;
* nested attributes (dicts, lists of lists) are JSON strings, so ``ds.to_netcdf()`` writes them (netCDF
  attributes are numbers, strings or flat arrays).
"""
from __future__ import annotations

import json
import os

import numpy as np

from .labels import LABELS, label_array
from .recipe import is_recipe


def _netcdf_attr(v):
    """``v`` as a netCDF attribute: a str, a number or a flat list of numbers as they are, anything else JSON."""
    if isinstance(v, (str, int, float, np.generic)) and not isinstance(v, bool):
        return v
    if isinstance(v, (list, tuple)) and v and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                  for x in v):
        return list(v)
    return json.dumps(v, sort_keys=True)


def open_dataset(path: str | os.PathLike, storage_options: dict | None = None):
    """Open a complete svgen store (any kind) as an analysis-ready dataset.

    Args:
        path: the store (local path or ``s3://`` URL).
        storage_options: s3fs options of an ``s3://`` store.

    Returns:
        an :class:`xarray.Dataset`: maps ``(sample, y, x, c)`` float32, images ``(sample, view_index, y, x, rgb)``
        uint8 sRGB codes as stored, ``preset`` ``(sample, parent)`` / ``category`` ``(sample,)`` string
        coordinates ("" where the index is -1), chunked by shard along ``sample``.

    Raises:
        StoreError: not a complete svgen store (checked by :func:`storage.store.open_store`).
    """
    import xarray as xr

    from .store import open_store

    g = open_store(path, ("variants", "blends", "stress", "renders"))
    shard = int(dict(g.attrs)["svgen"]["chunk"])
    kw = {"storage_options": storage_options} if storage_options else {}
    ds = xr.open_zarr(str(path), chunks={"sample": shard}, **kw)
    if is_recipe(dict(g.attrs)):  # no stored maps: mixed from the source variants store, lazily, shard by shard
        ds = ds.assign(_lazy_maps(path, shard))
    elif g.attrs["svgen"]["kind"] == "renders" and "diffuse" not in g:  # format 6: read from its inputs, lazily
        ds = ds.assign(_lazy_maps(path, shard, renders=True))
    for name in list(ds.data_vars):
        var = ds[name]
        if "scale_factor" in var.encoding and var.dtype == np.float64:
            out = var.astype(np.float32)
            out.attrs, out.encoding = var.attrs, dict(var.encoding)
            ds[name] = out
    attrs = dict(g.attrs)
    # the stored name arrays (storage.labels) duplicate the string coordinates made below under the index's own name
    ds = ds.drop_vars([label_array(i) for i in LABELS if label_array(i) in ds.variables])
    for index, labels in LABELS.items():
        if index in ds.data_vars and attrs.get(labels):
            names = np.array([*attrs[labels], ""], dtype=str)  # -1 picks the ""
            idx, dims, a = np.asarray(ds[index].values), ds[index].dims, ds[index].attrs
            ds = ds.drop_vars(index).assign_coords(
                {index: (dims, names[idx],
                         {"long_name": a.get("long_name", index), "comment": f"from group attribute {labels!r}"})})
    ds.attrs = {k: _netcdf_attr(v) for k, v in ds.attrs.items()}
    for name in ds.variables:
        ds[name].attrs = {k: _netcdf_attr(v) for k, v in ds[name].attrs.items()}
    return ds


def _lazy_maps(path, shard: int, renders: bool = False) -> dict:
    """The four maps of a recipe blends store (:mod:`storage.recipe`) as lazy float32 variables, one dask task
    per shard mixing its blends, decoded from the codes a stored-maps store holds, with its CF encoding (so
    ``to_netcdf`` writes the codes) and the same attributes. ``renders``: the base maps of a renders store without
    maps (format version 6), read from its inputs (:mod:`storage.renders_inputs`), as a version-4 store holds
    them (dimensions ``base_y``, ``base_x``)."""
    import dask
    import dask.array as da
    import xarray as xr

    from materials.maps import MAP_NAMES, MAP_SLICES, N_CHANNELS

    from .svbrdf_store import SVBRDFStore, map_specs

    def reader():  # each task its own (no shared cache)
        if renders:
            from .renders_store import RendersReader
            return RendersReader(path, cache_bytes=0)
        return SVBRDFStore(path, "blends")

    st = reader()  # here, not in the tasks only: a missing source fails in one line now
    n, size = (st.n_svbrdf, st.base_res) if renders else (len(st), st.size)

    def packed(a: int, b: int) -> np.ndarray:  # (b - a, S, S, 10) uint16
        r = reader()
        if renders:
            return np.stack([np.concatenate([c[k] for k in MAP_NAMES], axis=-1)
                             for c in map(r.base_codes, range(a, b))])
        codes = r.codes_range(a, b)
        return np.concatenate([codes[k] for k in MAP_NAMES], axis=-1)

    blocks = [da.from_delayed(dask.delayed(packed)(a, min(n, a + shard)), (min(n, a + shard) - a, size, size,
                                                                            N_CHANNELS), np.uint16)
              for a in range(0, n, shard)]
    codes = da.concatenate(blocks) if blocks else da.zeros((0, size, size, N_CHANNELS), np.uint16)
    out = {}
    for k, spec in map_specs(size, *((("base_y", "base_x"),) if renders else ())).items():
        attrs = spec.array_attrs()
        sf, ao = attrs.pop("scale_factor"), attrs.pop("add_offset")
        # as xarray decodes a stored map (in float64, code * scale_factor + add_offset), then float32 as above
        v = xr.DataArray((codes[..., MAP_SLICES[k]].astype(np.float64) * sf + ao).astype(np.float32),
                         dims=spec.dimension_names(k), attrs=attrs)
        v.encoding = {"dtype": np.dtype(spec.dtype), "scale_factor": sf, "add_offset": ao}
        out[k] = v
    return out
