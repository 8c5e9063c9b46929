"""The renders store (kind "renders") and its reader.

Layout (zarr v3 group; the sample axis is the SVBRDF, N of them, each with V views, chunked along N):

| array          | shape              | dtype   | meaning                                                        |
|----------------|--------------------|---------|----------------------------------------------------------------|
| image          | (N, V, R, R, 3)    | uint8   | linear LDR render, stored sRGB-encoded (see srgb8.py)          |
| view           | (N, V, 7)          | float64 | ViewParams: light_x, light_y, zoom, rotation, shift_u, shift_v, seed |
| normal ...     | (N, B, B, C)       | uint16  | the base maps, bytes copied from the input store (svbrdf_store); |
|                |                    |         | only with ``render.maps: stored`` (format version 4)           |
| source         | (N,)               | int64   | index of the SVBRDF in its input store                         |
| source_seed    | (N,)               | uint64  | that sample's seed in its input store                          |
| input          | (N,)               | int16   | which input store: index into attrs["inputs"]                  |
| preset         | (N, 2)             | int32   | base material(s): index into attrs["presets"] (-1: none)       |
| category       | (N,)               | int16   | stress category: index into attrs["categories"] (-1: none)     |

Base maps are not stored with ``render.maps: inputs`` (format version 6, the paper preset's): SVBRDF s's are sample
``source[s]`` of the input store ``inputs[input[s]]``, which :class:`RendersReader` reads (storage/renders_inputs.py,
checked against the recorded config hashes and seeds); keep the inputs beside the store. A version-4 store holds a
copy.

Aligned maps are not stored: a view's maps are recomputed from the stored base maps and the view's transform
(:func:`storage.views.transform_maps`), which is exactly how the renderer made its textures, so they
line up with the image pixel for pixel and cost no bytes. The decision and its numbers (bytes and read time
per view, stored vs recomputed) are in benchmarks/results/render.json (``storage``).

Group attributes beside the arrays: ``scene`` (its constants, the Mitsuba variant, a description in words),
``view_distribution``, ``inputs`` (paths relative to the store's directory), ``presets``, ``categories`` and
``split``: the held-out split of training's defaults (:mod:`svcore.split`), which ``svtrain`` reads back.

:class:`RendersReader` numbers views 0 .. N*V - 1 (view i is view i % V of SVBRDF i // V).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from materials.maps import MAP_NAMES, SVBRDF

from svcore.errors import StoreError

from storage.store import ArraySpec, ChunkCache, open_store, read_region
from storage.svbrdf_store import decode_maps, map_specs

from .renders_inputs import InputMaps
from .srgb8 import ENCODING, decode_srgb8
from .views import VIEW_FIELDS, VIEW_LONG_NAMES, VIEW_UNITS, ViewParams

KIND = "renders"


def array_specs(views: int, res: int, base: int, maps: bool = True) -> dict[str, ArraySpec]:
    """ArraySpecs of a renders store (one SVBRDF = one sample), with the per-array attributes a reader without
    svgen needs: the image's nonlinear encoding (no scale_factor: the sRGB curve is not linear), the units of
    every view parameter. ``maps``: with the base maps (format version 4), or without (version 6: read from the
    inputs)."""
    from storage.svbrdf_store import _index

    index = {k: _index(*a) for k, a in {
        "source": ("index of the SVBRDF in its input store",), "source_seed": ("seed of that SVBRDF in its input store",),
        "input": ("input store", "inputs"), "preset": ("base material(s)", "presets"),
        "category": ("stress category", "categories")}.items()}
    return {
        "image": ArraySpec((views, res, res, 3), "uint8", ENCODING, "linear sRGB primaries, stored sRGB-encoded",
                           ("view_index", "y", "x", "rgb"), IMAGE_ATTRS,
                           # level 3: level 1 would add 7-23 % to the largest array for a render-stage saving that
                           # 7 paired runs did not resolve (experiments/store_level_one)
                           zstd_level=3),
        "view": ArraySpec((views, len(VIEW_FIELDS)), "float64", "ViewParams fields: " + ", ".join(VIEW_FIELDS),
                          dims=("view_index", "view_field"), attrs=view_attrs()),
        **(map_specs(base, ("base_y", "base_x")) if maps else {}),
        "source": ArraySpec((), "int64", "index of the SVBRDF in its input store", attrs=index["source"]),
        "source_seed": ArraySpec((), "uint64", "seed of that SVBRDF in its input store", attrs=index["source_seed"]),
        "input": ArraySpec((), "int16", "which input store (index into attrs.inputs)", attrs=index["input"]),
        "preset": ArraySpec((2,), "int32", "base material(s): index into attrs.presets, -1 for none", dims=("parent",),
                            attrs=index["preset"]),
        "category": ArraySpec((), "int16", "stress category: index into attrs.categories, -1 for none",
                              attrs=index["category"]),
    }


#: the image array's attributes: 8-bit codes of the sRGB transfer function, deliberately without scale_factor
IMAGE_ATTRS = {
    "long_name": "flash photograph: linear low-dynamic-range radiance clipped to [0, 1]",
    "units": "1",
    "colour_space": "linear sRGB primaries (ITU-R BT.709, D65 white); stored sRGB-encoded",
    "transfer_function": "sRGB (IEC 61966-2-1)",
    "decode": "v = code / 255; linear = v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4",
    "comment": "the codes are NOT linear (no scale_factor on purpose): decode with the sRGB curve (e.g. "
               "colour.cctf_decoding(code / 255, 'sRGB')); row 0 is the top of the image",
}


def view_attrs() -> dict:
    """Attributes of the ``view`` array: its fields in order, with their units and meaning."""
    return {"long_name": "per-view light offset, texture transform and render seed",
            "fields": list(VIEW_FIELDS), "field_units": dict(VIEW_UNITS),
            "field_long_names": dict(VIEW_LONG_NAMES),
            "comment": "one row per view in the order of 'fields'; the aligned maps of a view are the base maps "
                       "under this transform (README.md of the store, 'Pairing an image with its maps')"}


class RendersReader:
    """Read access to a renders store: images, aligned maps, view parameters, provenance.

    Two caches make random access cheap: decoded store chunks (:class:`~storage.store.ChunkCache`) and the base
    maps of recently read SVBRDFs as drjit planes (what :meth:`crop` transforms). They share one byte budget, half
    each; a training loader gives every worker process its share of the run's budget (:meth:`set_cache_bytes`,
    train/loader_memory.py), since each worker holds its own copy of the reader.

    Args:
        path: a complete renders store.
        cache_bytes: bytes both caches may hold together (default :attr:`CACHE_BYTES`).

    Raises:
        StoreError: missing, incomplete, or not a renders store.
    """

    CACHE_BYTES = 2 << 30  # default budget of one reader's caches (half chunks, half planes: ~400 planes at 256^2)

    def __init__(self, path, cache_bytes: int | None = None):
        self.path = path
        self.group = open_store(path, KIND)
        self.attrs = dict(self.group.attrs)
        shape = self.group["image"].shape
        self.n_svbrdf, self.views, self.res = int(shape[0]), int(shape[1]), int(shape[2])
        #: None where the store holds its maps (version 4); else where they are read from (version 6)
        self.inputs = None if "diffuse" in self.group else InputMaps(self.group, path)
        self.base_res = int(self.group["diffuse"].shape[1]) if self.inputs is None else self.inputs.size
        self._cache = ChunkCache(self.group, 0)
        self._views: np.ndarray | None = None
        self._planes: dict[int, object] = {}  # SVBRDF -> its BaseTexels
        self.set_cache_bytes(self.CACHE_BYTES if cache_bytes is None else cache_bytes)

    @property
    def plane_bytes(self) -> int:
        """Bytes of one SVBRDF's base maps as the transform reads them (:class:`storage.views.BaseTexels`): 10
        float32 channels and 6 of padding per texel (:data:`storage.views.TEXEL_STRIDE`) at the base resolution."""
        from .views import TEXEL_STRIDE

        return self.base_res ** 2 * TEXEL_STRIDE * 4

    def min_cache_bytes(self) -> int:
        """The smallest useful budget: one chunk of every array a training read touches, plus one SVBRDF's planes
        (what a single :meth:`crop` holds at once), as half of the budget."""
        own = ("image", *MAP_NAMES) if self.inputs is None else ("image",)
        chunk = sum(math.prod(self.group[k].chunks) * self.group[k].dtype.itemsize for k in own)
        chunk += 0 if self.inputs is None else self.inputs.sample_bytes
        return 2 * max(chunk, self.plane_bytes)

    def set_cache_bytes(self, n: int) -> None:
        """Hold at most ``n`` bytes in the caches (half decoded chunks, half planes); evicts what is over. Without
        stored maps the chunk half is shared: the images' chunks and the inputs' in proportion to a read's bytes."""
        self.cache_bytes = int(n)
        chunks, share = self.cache_bytes // 2, 0
        if self.inputs is not None:
            img, per = math.prod(self.group["image"].chunks), self.inputs.sample_bytes
            share = chunks * per // (img + per)
            self.inputs.set_cache_bytes(share)
        self._cache.resize(chunks - share)
        self.plane_cache = max(1, self.cache_bytes // 2 // self.plane_bytes)  # SVBRDFs kept as planes
        while len(self._planes) > self.plane_cache:
            self._planes.pop(next(iter(self._planes)))

    @property
    def held_bytes(self) -> int:
        """Bytes the caches hold now (decoded chunks plus planes): at most :attr:`cache_bytes` and the planes' one
        SVBRDF of rounding (what a loader's memory budget counts)."""
        return (int(self._cache._bytes) + len(self._planes) * self.plane_bytes
                + (0 if self.inputs is None else self.inputs.held_bytes))

    def __len__(self) -> int:
        return self.n_svbrdf * self.views

    def _split(self, i: int) -> tuple[int, int]:
        i = int(i)
        if not 0 <= i < len(self):
            raise IndexError(f"view {i} out of range [0, {len(self)})")
        return divmod(i, self.views)

    def image(self, i: int) -> np.ndarray:
        """View i's render: (R, R, 3) float32 linear in [0, 1], numpy row 0 = image top."""
        s, v = self._split(i)
        return decode_srgb8(self.image_codes(s)[v])

    def image_codes(self, s: int) -> np.ndarray:
        """(V, R, R, 3) uint8: the sRGB-encoded codes of SVBRDF s's renders, as stored (not decoded)."""
        return self._cache.sample("image", s)

    def view_params(self, i: int) -> ViewParams:
        """View i's light offset, texture transform and seed."""
        s, v = self._split(i)
        if self._views is None:  # (N, V, 7) float64: small, read once
            self._views = read_region(self.group, "view", 0, self.n_svbrdf)
        return ViewParams.from_array(self._views[s, v])

    def base_maps(self, s: int) -> SVBRDF:
        """Tileable base maps of SVBRDF s (float32, decoded exactly as the renderer decoded them)."""
        return _base_maps_cached(self, int(s))

    def base_codes(self, s: int) -> dict[str, np.ndarray]:
        """The uint16 codes of SVBRDF s's base maps (map name -> (B, B, C)): stored, or read from its input."""
        if self.inputs is not None:
            return self.inputs.codes(s)
        try:
            return {k: self._cache.sample(k, s) for k in MAP_NAMES}
        except KeyError as e:
            raise StoreError(f"{self.path}: missing base map {e}") from None

    def maps(self, i: int) -> SVBRDF:
        """View i's maps, aligned with :meth:`image` pixel for pixel: (R, R, C) float32 SVBRDF in screen space."""
        from .views import transform_maps

        s, _ = self._split(i)
        return transform_maps(self.base_maps(s), self.view_params(i), self.res)

    def crop(self, i: int, row0: int, col0: int, size: int) -> tuple[np.ndarray, SVBRDF]:
        """A size x size window of view i: the image and the aligned maps of exactly those pixels.

        Equal to cropping :meth:`image` and :meth:`maps` (a test holds them together), but transforms only the
        window's pixels: what a training loader that crops 256 -> 128 needs.

        Returns:
            (size, size, 3) float32 linear image; SVBRDF of (size, size, C) maps.
        """
        from .views import svbrdf_of, texels_of, transform_planes

        s, v = self._split(i)
        if not (0 <= row0 and 0 <= col0 and row0 + size <= self.res and col0 + size <= self.res):
            raise IndexError(f"crop {size} at ({row0}, {col0}) leaves the {self.res}^2 view")
        if s not in self._planes:
            if len(self._planes) >= self.plane_cache:
                self._planes.pop(next(iter(self._planes)))
            self._planes[s] = texels_of(self.base_maps(s))
        planes = transform_planes(self._planes[s], self.base_res, self.view_params(i), self.res, (row0, col0, size))
        img = decode_srgb8(self._cache.sample("image", s)[v, row0:row0 + size, col0:col0 + size])
        return img, svbrdf_of(planes, size)

    def source(self, i: int) -> dict:
        """Provenance of view i: base material(s), stress category, input store and index, seeds."""
        s, v = self._split(i)
        src = self.attrs["inputs"][int(read_region(self.group, "input", s, s + 1)[0])]
        cat = int(read_region(self.group, "category", s, s + 1)[0])
        return {"view": int(i), "svbrdf": s, "view_in_svbrdf": v,
                "presets": list(self.presets_of_svbrdf()[s]),
                "category": self.attrs["categories"][cat] if cat >= 0 else None,
                "input_store": src["path"], "input_kind": src["kind"],
                "input_index": int(read_region(self.group, "source", s, s + 1)[0]),
                "input_seed": int(read_region(self.group, "source_seed", s, s + 1)[0]),
                "render_seed": self.view_params(i).seed}

    def presets_of_svbrdf(self) -> list[tuple[str, ...]]:
        """Base material names of every SVBRDF (one read; for splits by material)."""
        if not hasattr(self, "_presets"):
            names = self.attrs["presets"]
            self._presets = [tuple(names[p] for p in row if p >= 0) for row in self.group["preset"][:]]
        return self._presets

    def source_presets(self) -> list[tuple[str, ...]]:
        """Base material names of every view, in view order (one read; what a split by material needs)."""
        per = self.presets_of_svbrdf()
        return [p for p in per for _ in range(self.views)]

    def input_kinds_of_views(self) -> list[str]:
        """Kind of the input store (variants, blends, stress...) each view's SVBRDF was rendered from, one read."""
        kinds = [d["kind"] for d in self.attrs["inputs"]]
        per_svbrdf = [kinds[k] for k in self.group["input"][:]]
        return [k for k in per_svbrdf for _ in range(self.views)]

    def stored_split(self) -> dict | None:
        """The held-out split recorded at render time (``svcore.split.split_record``), None in older stores."""
        return self.attrs.get("split")

    def categories_of_views(self) -> list[str | None]:
        """Stress category of every view (None outside stress sets), one read."""
        cats = self.attrs["categories"]
        per_svbrdf = [cats[c] if c >= 0 else None for c in self.group["category"][:]]
        return [c for c in per_svbrdf for _ in range(self.views)]


@lru_cache(maxsize=8)
def _base_maps_cached(reader: RendersReader, s: int) -> SVBRDF:
    # the V views of one SVBRDF share its base maps: decode (and, from a recipe input, mix) them once
    return decode_maps(reader.base_codes(s))
