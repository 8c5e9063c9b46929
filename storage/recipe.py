"""Recipe blends stores: each blend's parents and weights, its maps mixed from the source variants store on read.

`svgen blend` writes a recipe store by default (``blend.maps: recipe``, store format version 5, #42): per blend
the two parents' indices in the variants store (``parents``), the weight exactly as mixed (``alpha``, float64)
and the mask seeds (``mask_seed``), with the rule's settings in the group attribute ``recipe``. No maps: at the
paper's scale the stored maps took 21 GB, a quarter of the data, for an intermediate that the render stage reads
once and copies into the renders store.

The maps of blend j are :func:`materials.blend.blend_pair` of its parents' decoded maps under
:func:`materials.blend.blend_weights` (:meth:`RecipeMaps.mix`), encoded by :class:`storage.svbrdf_store.SVBRDFStore`
with :func:`storage.svbrdf_store.encode_maps`: the same uint16 codes
that a stored-maps blends store (``blend.maps: stored``, and every store of format version 4 or older) holds, so
a renders store rendered from either is the same bytes (tests/test_blend_recipe.py).

The source variants store is found where the blends store records it (``inputs[0].path``, relative to the blends
store's folder: :func:`storage.local.recorded_path`), and must be the one it was made from (its ``config_hash``):
otherwise one line says so. Keep the two stores side by side (the DVC pipeline's data/ does).
"""
from __future__ import annotations

import os
import posixpath
from pathlib import Path

import numpy as np

from materials.blend import blend_pair, blend_weights

from svcore.errors import StoreError

from .local import read_region
from .objstore import is_object_url, local_path

#: the group attribute that makes a blends store a recipe store (its rule's settings)
RECIPE_ATTR = "recipe"


def is_recipe(attrs: dict) -> bool:
    """Whether a store's group attributes are a recipe blends store's (no maps; :class:`RecipeMaps` mixes them)."""
    return attrs.get("svgen", {}).get("kind") == "blends" and RECIPE_ATTR in attrs


def source_path(path, recorded: str) -> str:
    """Where the input recorded as ``recorded`` by the store at ``path`` is: a URL or an absolute path as recorded,
    a relative one from the store's folder (the inverse of :func:`storage.local.recorded_path`), on the object store
    too where ``path`` is a URL (a folder of stores uploaded together keeps its relative records)."""
    if is_object_url(recorded) or os.path.isabs(recorded):
        return recorded
    if is_object_url(path):
        head, key = str(path).rstrip("/").split("://", 1)
        return f"{head}://{posixpath.normpath(posixpath.join(posixpath.dirname(key), recorded))}"
    return str(Path(local_path(path)).resolve().parent / recorded)


class RecipeMaps:
    """The maps of a recipe blends store, mixed on read from its source variants store.

    Args:
        group: the blends store's zarr group (opened and checked by :func:`storage.store.open_store`).
        path: its path or URL (the source is recorded relative to it).
        open_source: ``(path, whole_shards) -> `` the variants store's reader (a
            :class:`storage.svbrdf_store.SVBRDFStore`, which passes its own opener: this module imports no reader).
        whole_shards: read the source in whole shards (a reader that will mix most blends); default: when the
            blends are at least half as many as the variants, as the blend stage decided for its own reads.

    Raises:
        StoreError: the source is missing, is not the store the blends were made from, or is too small for the
            recorded parents.
    """

    def __init__(self, group, path, open_source, whole_shards: bool | None = None):
        attrs = dict(group.attrs)
        self.rule, src = attrs[RECIPE_ATTR], attrs["inputs"][0]
        n = int(group["seed"].shape[0])
        where = source_path(path, src["path"])
        if whole_shards is None:
            whole_shards = 2 * n >= int(src.get("n", n))
        try:
            self.source = open_source(where, whole_shards)
        except StoreError as e:
            raise StoreError(f"{path} is a recipe blends store: its maps are mixed from the variants store it records "
                             f"as {src['path']!r}, which does not open ({e}). Keep the two stores side by side, or "
                             "re-run svgen blend") from None
        have = self.source.attrs["svgen"]["config_hash"]
        if have != src["config_hash"]:
            raise StoreError(f"{path} is a recipe blends store of the variants store with config hash "
                             f"{src['config_hash']}, but {where} has {have}: its maps would mix other materials. "
                             "Re-run svgen blend on this variants store")
        self.parents = read_region(group, "parents", 0, n).astype(np.int64)
        self.alpha = read_region(group, "alpha", 0, n).astype(np.float64)
        self.mask_seed = read_region(group, "mask_seed", 0, n).astype(np.uint64)
        if n and (self.parents.min() < 0 or self.parents.max() >= len(self.source)):
            raise StoreError(f"{path}: parents outside the {len(self.source)} variants of {where}")
        self.size = self.source.size

    def __len__(self) -> int:
        return len(self.parents)

    def mix(self, i: int):
        """Blend ``i``'s maps (float32 :class:`materials.SVBRDF`), mixed as the blend stage mixes them."""
        a, b = (int(x) for x in self.parents[i])
        w = blend_weights(self.size, self.alpha[i], self.mask_seed[i], self.rule["mode"], self.rule["mask_per_map"],
                          self.rule["mask_scale"])
        return blend_pair(self.source.maps(a), self.source.maps(b), w)
