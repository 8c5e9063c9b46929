"""Variants, blends and stress stores: SVBRDF maps per sample plus the table that says where each came from.

Layout (zarr v3 group, N samples of S x S maps, chunked along the sample axis):

| array      | shape         | dtype  | meaning                                                           |
|------------|---------------|--------|-------------------------------------------------------------------|
| normal     | (N, S, S, 3)  | uint16 | (n + 1) / 2 * 65535, tangent space, x right, y up                 |
| diffuse    | (N, S, S, 3)  | uint16 | linear RGB albedo * 65535                                         |
| specular   | (N, S, S, 3)  | uint16 | linear RGB F0 * 65535                                             |
| roughness  | (N, S, S, 1)  | uint16 | perceptual roughness * 65535 (alpha = r^2)                        |
| seed       | (N,)          | uint64 | the sample's derived seed                                         |
| preset     | (N, 2)        | int32  | index into attrs["presets"]; blends: both parents'; variants: -1 2nd |
| params     | (N, P)        | float32| variants: exposed parameters in the preset's table order, NaN-padded (none in an imported store) |
| parents    | (N, 2)        | int64  | blends only: variant indices in the source store                  |
| alpha      | (N,)          | float32| blends only: mean weight of the first parent (recipe store: float64, exactly as mixed) |
| mask_seed  | (N, 4)        | uint64 | recipe blends only: mask seeds of normal, diffuse, specular, roughness |
| category   | (N,)          | int16  | stress only: index into attrs["categories"]                       |
| light_radius | (N, 2)      | float32| stress only: light offset radius range of the sample's views      |

A recipe blends store (`svgen blend`'s default since format version 5, :mod:`storage.recipe`) holds no map
arrays: :class:`SVBRDFStore` mixes each blend's maps from its source variants store on read, to the codes a
stored-maps blends store holds.

16-bit: quantisation error 7.6e-6, far below what a render or the loss can see,
while 8-bit linear albedo would band in dark colours.
"""
from __future__ import annotations

import numpy as np

from materials.maps import MAP_CHANNELS, MAP_NAMES, SVBRDF, encode_normal, normalize

from svcore.errors import StoreError

from .recipe import RecipeMaps, is_recipe
from .store import ArraySpec, ChunkCache, open_store, read_region

KINDS = ("variants", "blends", "stress")
Q = 65535.0


#: the maps' CF attributes: their uint16 codes are linear encodings, so ``scale_factor``/``add_offset`` decode them
#: (xarray does it on open): value = code * scale_factor + add_offset.
LINEAR_SRGB = "linear sRGB primaries (ITU-R BT.709, D65 white), no transfer function"
MAP_ATTRS = {
    "normal": {"long_name": "surface normal in tangent space (x right, y up in the image, z out of the surface)",
               "units": "1", "scale_factor": 2.0 / Q, "add_offset": -1.0,
               "comment": "stored (n + 1) / 2 * 65535 rounded; a decoded normal is within 3e-5 of unit length: "
                          "renormalise it (svgen does); OpenGL convention (y up)"},
    "diffuse": {"long_name": "diffuse albedo", "units": "1", "scale_factor": 1.0 / Q, "add_offset": 0.0},
    "specular": {"long_name": "specular albedo F0 (GGX, Schlick Fresnel)", "units": "1", "scale_factor": 1.0 / Q,
                 "add_offset": 0.0},
    "roughness": {"long_name": "perceptual roughness r (GGX alpha = r^2)", "units": "1", "scale_factor": 1.0 / Q,
                  "add_offset": 0.0},
}
#: per-sample axis names of each map (roughness has one channel: its own axis name, since xarray needs one length
#: per name).
MAP_DIMS = {"normal": "xyz", "diffuse": "rgb", "specular": "rgb", "roughness": "roughness_channel"}


def map_specs(size: int, dims: tuple[str, str] = ("y", "x")) -> dict[str, ArraySpec]:
    """ArraySpecs of the four maps at ``size``²; ``dims``: the names of their row and column axes."""
    enc = {"normal": "(n+1)/2 * 65535", "diffuse": "linear * 65535", "specular": "linear * 65535",
           "roughness": "perceptual roughness * 65535 (alpha = r^2)"}
    space = {"normal": "tangent (x right, y up, z out)", "diffuse": LINEAR_SRGB, "specular": LINEAR_SRGB,
             "roughness": "n/a"}
    return {k: ArraySpec((size, size, c), "uint16", enc[k], space[k], (*dims, MAP_DIMS[k]), MAP_ATTRS[k])
            for k, c in MAP_CHANNELS.items()}


def _index(long_name: str, into: str | None = None, **kw) -> dict:
    """CF attributes of an integer array that is an identifier or an index into a group attribute list."""
    a = {"long_name": long_name, **kw}
    if into:
        a["comment"] = f"index into the group attribute {into!r}; -1: none"
    return a


def array_specs(kind: str, size: int, max_params: int = 0, recipe: bool = False) -> dict[str, ArraySpec]:
    """ArraySpecs of a variants, blends or stress store (the table above) with maps at ``size``².

    Args:
        kind: "variants", "blends" or "stress".
        size: map resolution.
        max_params: variants only: columns of ``params`` (the largest exposed-parameter count of its presets);
            0: no ``params`` array (an imported store, `svgen import`: its materials have no parameters).
        recipe: blends only: a recipe store (:mod:`storage.recipe`): no maps, each blend's exact ``alpha``
            (float64) and its four ``mask_seed``, from which a reader mixes the maps.
    """
    seed = {"variants": "derived variant seed", "blends": "derived blend seed", "stress": "derived sample seed"}
    seed_attrs = {k: _index(v, comment="svcore.seeds.derive_seed of the stage's master seed and the sample index")
                  for k, v in seed.items()}
    per_kind = {
        "variants": {"params": ArraySpec((max_params,), "float32", "exposed parameters in table order, NaN-padded",
                                         dims=("param",), attrs={
                                             "long_name": "the preset's exposed parameters, in its table order",
                                             "comment": "names per preset: group attribute 'param_names'; NaN: "
                                                        "beyond the preset's parameter count"}),
                     "seed": ArraySpec((), "uint64", seed["variants"], attrs=seed_attrs["variants"]),
                     "preset": ArraySpec((2,), "int32", "index into attrs.presets; second column -1", dims=("parent",),
                                         attrs=_index("base material", "presets"))},
        "blends": {"seed": ArraySpec((), "uint64", seed["blends"], attrs=seed_attrs["blends"]),
                   "parents": ArraySpec((2,), "int64", "variant indices (a, b) in the source store", dims=("parent",),
                                        attrs=_index("indices of the two blended variants (a, b) in the source store")),
                   "preset": ArraySpec((2,), "int32", "presets of a and b: index into attrs.presets", dims=("parent",),
                                       attrs=_index("base materials of a and b", "presets")),
                   "alpha": ArraySpec((), "float32", "weight of parent a (mask mode: expected mask mean)",
                                      attrs={"long_name": "weight of parent a (mask mode: the mask's mean)",
                                             "units": "1"})},
        "stress": {"seed": ArraySpec((), "uint64", seed["stress"], attrs=seed_attrs["stress"]),
                   "category": ArraySpec((), "int16", "index into attrs.categories",
                                         attrs=_index("stress category", "categories")),
                   "light_radius": ArraySpec((2,), "float32", "light offset radius range of its views (NaN: default)",
                                             dims=("bound",), attrs={
                                                 "long_name": "light offset radius range (min, max) of its views",
                                                 "units": "camera-plane world units (the material plane spans "
                                                          "[-1, 1])", "comment": "NaN: the default range"}),
                   "preset": ArraySpec((2,), "int32", "-1: stress samples mix or alter presets", dims=("parent",),
                                       attrs=_index("base material (-1: stress samples mix or alter presets)"))},
    }
    if kind not in per_kind:
        raise ValueError(f"unknown SVBRDF store kind {kind!r}; known: {', '.join(per_kind)}")
    if kind == "variants" and max_params == 0:
        del per_kind["variants"]["params"]
    if recipe:
        if kind != "blends":
            raise ValueError(f"only a blends store can be a recipe store, not {kind!r}")
        return {**per_kind["blends"], **RECIPE_SPECS}
    return {**map_specs(size), **per_kind[kind]}


#: the arrays a recipe blends store adds to (or changes in) a blends store's: the weight exactly as the stage used
#: it (float64: the mix computes 1 - alpha in double precision, so a float32 copy would change stored codes), and
#: the mask seeds (mask mode; drawn in scalar mode too, so the stream is the same in both).
RECIPE_SPECS = {
    "alpha": ArraySpec((), "float64", "weight of parent a, exactly as mixed (mask mode: the masks' expected mean)",
                       attrs={"long_name": "weight of parent a (mask mode: the masks' expected mean)", "units": "1"}),
    "mask_seed": ArraySpec((4,), "uint64", "seeds of the masks of normal, diffuse, specular, roughness (mask mode)",
                           dims=("map",), attrs={"long_name": "mask seed per map (normal, diffuse, specular, "
                                                 "roughness); mask mode only, the first for all with one mask"}),
}


def encode_maps(m: SVBRDF, out: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """SVBRDF -> on-disk uint16 arrays (one sample, no batch axis); with ``out`` (map name -> uint16 array of the
    sample's shape, e.g. a row of a chunk's array) written into those and returned, not allocated."""
    res = {}
    for k in MAP_NAMES:
        a = encode_normal(m.normal) if k == "normal" else getattr(m, k)
        t = np.clip(a, 0.0, 1.0)  # a new array: scaled and rounded in place (two fewer temporaries per map)
        t *= Q
        np.round(t, out=t)
        if out is None:
            res[k] = t.astype(np.uint16)
        else:  # the cast astype does (float32 -> uint16), into the caller's array
            np.copyto(out[k], t, casting="unsafe")
            res[k] = out[k]
    return res


def encode_row(chunk: dict[str, np.ndarray], n: int, j: int, m: SVBRDF) -> None:
    """Encode sample ``m`` into row ``j`` of a chunk's uint16 map arrays (the sample and blend tasks' loop): the
    arrays, ``n`` rows of m's map shapes, are allocated into ``chunk`` at its first sample (no per-sample copies)."""
    if not all(k in chunk for k in MAP_NAMES):
        chunk.update({k: np.empty((n, *getattr(m, k).shape), np.uint16) for k in MAP_NAMES})
    encode_maps(m, {k: chunk[k][j] for k in MAP_NAMES})


def decode_maps(d: dict[str, np.ndarray]) -> SVBRDF:
    """On-disk arrays (one sample) -> float32 SVBRDF (normals renormalised)."""
    vals = {k: d[k].astype(np.float32) / Q for k in MAP_NAMES}
    # no z clamp here: a store with invalid normals must fail validate(), not be silently repaired
    vals["normal"] = normalize(vals["normal"] * 2.0 - 1.0)
    return SVBRDF(**vals)


class SVBRDFStore:
    """Read access to a variants or blends store.

    Whole chunks are kept decoded up to CACHE_BYTES (the paper's 1,850 variants at 256^2 take 2.4 GB), so random
    access, as blending does, decompresses every chunk once per process rather than once per sample.

    Args:
        path: store path.
        kind: accepted kinds (default both).
        cache_bytes: bytes of decoded chunks kept (default :attr:`CACHE_BYTES`; a sequential reader needs one
            chunk).
        whole_shards: the cache reads whole shards (:class:`~storage.local.ChunkCache`), for a reader that will
            touch most samples.
        source_whole_shards: a recipe store's source variants store reads whole shards (default: as
            :class:`storage.recipe.RecipeMaps` decides; False for random access, as a training read does).
    """

    CACHE_BYTES = 3 << 30

    def __init__(self, path, kind: str | tuple[str, ...] = KINDS, cache_bytes: int | None = None,
                 whole_shards: bool = False, source_whole_shards: bool | None = None):
        self.path = path
        self.group = open_store(path, kind)
        self.attrs = dict(self.group.attrs)
        self.kind = self.attrs["svgen"]["kind"]
        self.presets: list[str] = list(self.attrs.get("presets", []))
        #: a recipe blends store's mixer (storage.recipe): no maps stored, each blend mixed from its parents on read
        self.recipe = (RecipeMaps(self.group, path, _open_variants, source_whole_shards) if is_recipe(self.attrs)
                       else None)
        self.size = self.recipe.size if self.recipe else int(self.group["diffuse"].shape[1])
        self._cache = ChunkCache(self.group, self.CACHE_BYTES if cache_bytes is None else cache_bytes, whole_shards)

    def __len__(self) -> int:
        return int(self.group["seed" if self.recipe else "diffuse"].shape[0])

    def maps(self, i: int) -> SVBRDF:
        """Maps of sample ``i`` (float32, linear).

        Reads go through a per-store cache of whole chunks: random access (blending picks pairs at random)
        would otherwise decompress a whole chunk for every single sample.
        """
        return decode_maps(self.codes(i))

    def codes(self, i: int) -> dict[str, np.ndarray]:
        """The stored uint16 codes of sample ``i``'s maps (map name -> (S, S, C)), not decoded (through the cache)."""
        if self.recipe:
            return encode_maps(self.recipe.mix(i))
        return {k: self._cache.sample(k, i) for k in MAP_NAMES}

    def codes_range(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """The uint16 codes of samples [start, stop) (map name -> (n, S, S, C)), one read per array; a recipe
        blends store's mixed as a stored-maps store would hold them."""
        if not self.recipe:
            return {k: read_region(self.group, k, start, stop) for k in MAP_NAMES}
        out = {k: np.empty((stop - start, self.size, self.size, c), np.uint16) for k, c in MAP_CHANNELS.items()}
        for j in range(stop - start):
            encode_row(out, stop - start, j, self.recipe.mix(start + j))
        return out

    def maps_range(self, start: int, stop: int) -> list[SVBRDF]:
        """Maps of samples [start, stop) with one read per array (fast for whole chunks)."""
        raw = self.codes_range(start, stop)
        return [decode_maps({k: raw[k][j] for k in MAP_NAMES}) for j in range(stop - start)]

    def preset_table(self) -> np.ndarray:
        """(N, 2) int32 preset indices of every sample (read once, then cached)."""
        if not hasattr(self, "_presets"):
            self._presets = read_region(self.group, "preset", 0, len(self))
        return self._presets

    def source(self, i: int) -> dict:
        """Where sample ``i`` came from: its preset(s), classes and seed."""
        pre = read_region(self.group, "preset", i, i + 1)[0]
        names = [self.presets[p] for p in pre if p >= 0]
        return {"id": int(i), "kind": self.kind, "presets": names, "classes": sorted({n.split("/")[0] for n in names}),
                "seed": int(read_region(self.group, "seed", i, i + 1)[0])}

    def check_maps(self, i: int) -> SVBRDF:
        """Maps of sample ``i``, validated against DESIGN.md (StoreError naming the sample otherwise)."""
        m = self.maps(i)
        try:
            return m.validate(normal_tol=1e-3)
        except ValueError as e:
            raise StoreError(f"{self.path}: sample {i}: {e}") from None


def _open_variants(path, whole_shards: bool) -> SVBRDFStore:
    """A recipe blends store's source (storage.recipe.RecipeMaps opens it through this: it imports no reader)."""
    return SVBRDFStore(path, "variants", whole_shards=whole_shards)


class SVBRDFInputs:
    """Several variants/blends/stress stores read as one sequence (render inputs), in the order given.

    Global sample s is local sample ``s - offset[k]`` of input k. Preset indices of every input are remapped
    into one list (:attr:`presets`), so provenance survives the concatenation.

    Args:
        paths: one or more store paths.
    """

    def __init__(self, paths):
        paths = [paths] if isinstance(paths, (str, bytes)) or hasattr(paths, "__fspath__") else list(paths)
        if not paths:
            raise StoreError("no input store given")
        self.paths = [str(p) for p in paths]
        self.stores = [SVBRDFStore(p, KINDS) for p in self.paths]
        sizes = {s.size for s in self.stores}
        if len(sizes) != 1:
            raise StoreError(f"input stores have different map sizes {sorted(sizes)}; render them separately")
        self.size = sizes.pop()
        self.offsets = np.cumsum([0] + [len(s) for s in self.stores])
        self.presets: list[str] = sorted({p for s in self.stores for p in s.presets})
        self.categories: list[str] = sorted({c for s in self.stores for c in s.attrs.get("categories", [])})
        self._remap = [np.array([self.presets.index(p) for p in s.presets] + [-1], np.int32) for s in self.stores]

    def __len__(self) -> int:
        return int(self.offsets[-1])

    def describe(self, out=None) -> list[dict]:
        """Identity of every input (path, kind, size, config hash) for the attributes of a derived store.

        Args:
            out: the store being written from them: the paths are recorded relative to its directory (the same
                string for any spelling of the same input). None records them as given.
        """
        from .store import recorded_path

        return [{"path": p if out is None else recorded_path(p, out), "kind": s.kind, "n": len(s),
                 "config_hash": s.attrs["svgen"]["config_hash"]} for p, s in zip(self.paths, self.stores)]

    def segments(self, start: int, stop: int):
        """Yield (input index, local start, local stop) covering global samples [start, stop)."""
        for k, s in enumerate(self.stores):
            a, b = max(start, self.offsets[k]), min(stop, self.offsets[k + 1])
            if a < b:
                yield k, int(a - self.offsets[k]), int(b - self.offsets[k])

    def read(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Raw arrays of global samples [start, stop): the four maps (on-disk uint16), ``seed``, ``input``,
        ``index`` (local), ``preset`` (remapped, (n, 2)), ``category`` (-1 if none), ``light_radius`` (NaN if none).
        """
        parts = []
        for k, a, b in self.segments(start, stop):
            g = self.stores[k].group
            d = self.stores[k].codes_range(a, b)
            d["seed"] = read_region(g, "seed", a, b).astype(np.uint64)
            d["input"] = np.full(b - a, k, np.int16)
            d["index"] = np.arange(a, b, dtype=np.int64)
            d["preset"] = self._remap[k][read_region(g, "preset", a, b)]
            cats = self.stores[k].attrs.get("categories", [])
            d["category"] = (np.array([self.categories.index(c) for c in cats], np.int16)[read_region(g, "category", a, b)]
                             if "category" in g else np.full(b - a, -1, np.int16))
            d["light_radius"] = (read_region(g, "light_radius", a, b).astype(np.float32) if "light_radius" in g
                                 else np.full((b - a, 2), np.nan, np.float32))
            parts.append(d)
        return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
