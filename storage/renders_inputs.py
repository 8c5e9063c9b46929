"""The base maps of a renders store without maps (format version 6, ``render.maps: inputs``), read from its inputs.

`svgen render` copied every SVBRDF's base maps into the renders store (format version 4): at the paper's scale about
22 of its 57 GB, bytes the variants store (and, through its recipe, the blends store) already hold. A version-6
renders store records, per SVBRDF, which input store (``input``, an index into the group attribute ``inputs``) and
which sample of it (``source``, with that sample's seed in ``source_seed``) it rendered. :class:`InputMaps` opens
those inputs where they are recorded (relative to the renders store's folder: :func:`storage.local.recorded_path`)
and reads SVBRDF s's codes from them: the very codes the render stage decoded and rendered, and the codes a
version-4 store holds (a recipe blends input mixes them exactly as the render did: tests/test_render_maps_inputs.py).

Opening checks what would make the maps silently wrong: every input opens, is of its recorded kind and size and has
the recorded config hash, and every SVBRDF's recorded seed is its input sample's seed. Anything else is refused in
one line that says to keep the inputs beside the store or to re-render.
"""
from __future__ import annotations

import numpy as np

from materials.maps import N_CHANNELS

from svcore.errors import StoreError

from .recipe import source_path
from .store import read_region


class InputMaps:
    """SVBRDF s's base-map codes of a renders store without maps, read from the input stores it records.

    Args:
        group: the renders store's zarr group (opened and checked by :func:`storage.store.open_store`).
        path: its path or URL (the inputs are recorded relative to it).

    Raises:
        StoreError: an input is missing or not the store the renders were made from.
    """

    def __init__(self, group, path):
        from .svbrdf_store import SVBRDFStore

        attrs = dict(group.attrs)
        n = int(group["image"].shape[0])
        self.input = read_region(group, "input", 0, n).astype(np.int64)
        self.source = read_region(group, "source", 0, n).astype(np.int64)
        seeds = read_region(group, "source_seed", 0, n).astype(np.uint64)
        self.stores = []
        for k, rec in enumerate(attrs["inputs"]):
            where = source_path(path, rec["path"])
            try:  # random access: the source of a recipe store is read sample by sample, not in whole shards
                st = SVBRDFStore(where, rec["kind"], cache_bytes=0, source_whole_shards=False)
            except StoreError as e:
                raise StoreError(f"{path} stores no maps: it reads them from the {rec['kind']} store it records as "
                                 f"{rec['path']!r}, which does not open ({e}). Keep its input stores beside it, or "
                                 "re-render with render.maps=stored") from None
            have = st.attrs["svgen"]["config_hash"]
            if have != rec["config_hash"] or len(st) != int(rec["n"]):
                raise StoreError(f"{path} was rendered from a {rec['kind']} store of {rec['n']} samples with config "
                                 f"hash {rec['config_hash']}, but {where} has {len(st)} with {have}: its maps would "
                                 "not be the rendered ones. Re-render from this store")
            mine = self.input == k
            if mine.any() and not np.array_equal(
                    read_region(st.group, "seed", 0, len(st)).astype(np.uint64)[self.source[mine]], seeds[mine]):
                raise StoreError(f"{path}: the seeds of {where} are not the ones it rendered: re-render from it")
            self.stores.append(st)
        self.size = self.stores[0].size if self.stores else 0

    @property
    def caches(self) -> list:
        """The chunk caches the maps are read through (a recipe store's: its source variants store's)."""
        return [(st.recipe.source if st.recipe else st)._cache for st in self.stores]

    @property
    def sample_bytes(self) -> int:
        """Decoded bytes one SVBRDF's read holds at most: one sample's codes, two when an input mixes its parents."""
        return self.size ** 2 * N_CHANNELS * 2 * (2 if any(st.recipe for st in self.stores) else 1)

    def set_cache_bytes(self, n: int) -> None:
        """Share ``n`` bytes among the inputs' chunk caches (evicting what is over)."""
        caches = self.caches
        for c in caches:
            c.resize(max(0, int(n)) // max(1, len(caches)))

    @property
    def held_bytes(self) -> int:
        return sum(int(c._bytes) for c in self.caches)

    def codes(self, s: int) -> dict[str, np.ndarray]:
        """The uint16 codes of SVBRDF s's base maps (map name -> (B, B, C)), as a version-4 store holds them."""
        return self.stores[int(self.input[s])].codes(int(self.source[s]))
