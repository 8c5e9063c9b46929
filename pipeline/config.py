"""The typed configurations of the svgen stages and their presets (the mechanism: :mod:`svcore.config`).

Every field's attribute docstring is its ``--help`` text and its params.yaml documentation. The resolved
configuration is stored in the attributes of the store a stage writes.
"""
from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

from pydantic import ConfigDict, Field, model_validator

from materials.registry import MAX_SIZE, MIN_SIZE
from svcore.config import ConfigModel

#: ``Field(strict=False)`` on list fields: YAML gives lists, the config keeps tuples (hashable, frozen).
_LIST = {"strict": False}


class StageConfig(ConfigModel):
    """A data stage's config: frozen (it travels to dask workers and into the store's config hash)."""

    model_config = ConfigDict(frozen=True)


class SampleConfig(StageConfig):
    """`svgen sample`: perturbed variants of every base material."""

    SECTION: ClassVar[str] = "sample"
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "default": {}, "tiny": {"per_preset": 2, "size": 64, "chunk": 8}, "paper": {"per_preset": 10, "size": 288}}

    per_preset: int = Field(12, ge=1)
    """Variants per base material (the paper's scale, ~1,850 variants, is the paper preset's value:
    --config-preset paper --print-config). Variant 0 is the preset's defaults; the others are perturbed."""
    size: int = Field(256, ge=MIN_SIZE, le=MAX_SIZE)
    """Map resolution (square; the material generators' range, any integer in it)."""
    seed: int = Field(0, ge=0, lt=2 ** 64)
    """Master seed of the stage; variant k of preset P uses derive_seed(seed, "sample", crc32(P), k)."""
    sigma: float = Field(0.25, gt=0, le=10)
    """Perturbation: each exposed parameter ~ Normal(default, sigma * (high - low)) truncated to [low, high]."""
    presets: tuple[str, ...] = Field((), **_LIST)
    """Only these base materials (class/name, as `svgen materials` lists them; empty: all)."""
    classes: tuple[str, ...] = Field((), **_LIST)
    """Only these material classes (empty: all)."""
    chunk: int = Field(64, ge=1)
    """Samples per task: one dask task writes one zarr shard per array (the store's objects; the resume unit).
    64 like render.chunk (docs/CODECS.md)."""
    from_stores: tuple[str, ...] = Field((), **_LIST)
    """Imported variants stores (`svgen import`) whose materials are perturbed too: per_material variants of
    each, after the presets' variants (pipeline/sample_from.py)."""
    from_dir: str | None = None
    """A folder whose *.zarr stores join from_stores (sorted by name; a missing or empty folder adds none: the
    DVC pipeline's data/imported)."""
    per_material: int = Field(3, ge=1)
    """Variants per imported material; variant k of material P uses derive_seed(seed, "sample", crc32(P), k)
    and the generic table of pipeline/importer/perturb.py."""
    only_from: bool = False
    """With imported stores: write only the imported materials' variants, no presets'."""
    relief: float = Field(0.06, ge=0, le=2)
    """Extra relief on every variant: RMS slope of a band-limited height field added to its own (0: none).
    The default is fine grain, 0.06 at 64 cycles per map (4-pixel periods at 256²), where real materials put most
    of their slope power (docs/REALISM.md). Presets' variants only, after the relief mode: an imported material's
    variants keep its measured relief. Normals come from the summed heights' slopes."""
    relief_cycles: float = Field(64.0, ge=1, le=128)
    """Centre of the extra relief's band, cycles per map width (about one octave wide)."""
    relief_spread: float = Field(1.0, ge=0, le=2)
    """Spread of the extra relief's RMS slope across variants: each variant's is ``relief`` x exp(relief_spread x z),
    z ~ Normal(0, 1) from its own seed (0: every variant gets exactly ``relief``). The spread of grain amplitudes
    between materials; ``relief_patches`` varies it within one (docs/REALISM.md)."""
    relief_patches: float = Field(1.2, ge=0, le=2)
    """Patchiness of the extra relief within a material: its height is multiplied by exp(p x g), g a smooth unit
    Gaussian field (about 4 features per map) and p ~ Uniform(0, relief_patches) per variant, then rescaled to
    the variant's RMS slope (0: uniform grain). A uniform grain has one CV of slope magnitude (a Gaussian field's,
    0.52) whatever its amplitude; real materials spread 0.2-1.4 (docs/REALISM.md)."""
    flat_share: float = Field(0.35, ge=0, le=1)
    """Share of variants made with flat normals, colour, specular and roughness kept: the printed, polished or
    painted-over counterpart of a textured material, so that colour texture alone never means relief. Presets'
    variants only: an imported material's variants keep its measured relief."""
    swap_share: float = Field(0.35, ge=0, le=1)
    """Share of variants whose relief is replaced by an independent random height field
    (materials.heights.independent_relief), so that relief and colour texture vary independently."""
    flat_grain: bool = True
    """Whether the flat variants (``flat_share``) get the extra grain (``relief``) too. False: they stay truly flat,
    as a print or paint on a smooth surface is; with True the library holds no flat material at all (its flattest
    views have the grain's relief), which real prints and polished stone have."""

    #: the keys of imported materials; a store without imported stores records the config without them, so that
    #: it is exactly what a plain `svgen sample` writes (the default DVC pipeline passes an empty --from-dir).
    IMPORT_KEYS: ClassVar[tuple[str, ...]] = ("from_stores", "from_dir", "per_material", "only_from")
    #: the extra-relief keys: a store without extra relief records the config without them (same bytes as before).
    RELIEF_KEYS: ClassVar[tuple[str, ...]] = ("relief", "relief_cycles")
    #: the relief-mode keys (flat and independent relief), likewise left out of the recorded config at 0.
    MODE_KEYS: ClassVar[tuple[str, ...]] = ("flat_share", "swap_share")
    #: the amplitude spread and patchiness of the extra relief, likewise left out of the recorded config at 0.
    SPREAD_KEYS: ClassVar[tuple[str, ...]] = ("relief_spread", "relief_patches")
    #: whether flat variants get the grain, likewise left out of the recorded config at True (the stores before it).
    GRAIN_KEYS: ClassVar[tuple[str, ...]] = ("flat_grain",)

    @model_validator(mode="after")
    def _only_from_needs_stores(self) -> "SampleConfig":
        if self.only_from and not self.from_stores and self.from_dir is None:
            raise ValueError("only_from needs imported stores (from_stores or from_dir)")
        if self.flat_share + self.swap_share > 1:
            raise ValueError(f"flat_share + swap_share is {self.flat_share + self.swap_share:g}: shares of the "
                             f"variants, together at most 1")
        return self

    def dropped_keys(self) -> tuple[str, ...]:
        """Keys left out of the recorded config because they are at their no-op value (same bytes as before)."""
        return ((self.RELIEF_KEYS if self.relief == 0 else ())
                + tuple(k for k in self.MODE_KEYS + self.SPREAD_KEYS if getattr(self, k) == 0)
                + (self.GRAIN_KEYS if self.flat_grain else ()))


class BlendConfig(StageConfig):
    """`svgen blend`: convex combinations of random pairs of variants."""

    SECTION: ClassVar[str] = "blend"
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {"default": {}, "tiny": {"count": 6, "chunk": 8}, "paper": {"count": 20000}}

    count: int = Field(120, ge=1)
    """Number of blends (the paper: ~10x the number of variants)."""
    seed: int = Field(0, ge=0, lt=2 ** 64)
    """Master seed; blend j uses derive_seed(seed, "blend", j) for its pair, alpha and mask."""
    alpha_low: float = Field(0.2, ge=0, le=1)
    """Lower end of alpha ~ U(alpha_low, alpha_high): weight of the first variant."""
    alpha_high: float = Field(0.8, ge=0, le=1)
    """Upper end of the alpha range."""
    mode: Literal["scalar", "mask"] = "scalar"
    """scalar: one alpha for the whole maps (the paper); mask: a tileable procedural mask in [0,1] whose mean is
    alpha, so the two materials occupy different regions."""
    mask_per_map: bool = False
    """Mask mode: a different mask per map (normal, diffuse, specular, roughness), decorrelating the maps."""
    mask_scale: float = Field(4.0, ge=0.5, le=64)
    """Mask mode: features per tile of the mask noise (larger: finer patches)."""
    maps: Literal["recipe", "stored"] = "recipe"
    """recipe: store each blend's parents, weight and mask seeds, and mix its maps from the variants store when
    they are read (render, gallery, stats: the same codes, no map bytes; keep the variants store beside it);
    stored: store the mixed maps too (a self-contained store, about 1 MB per 288² blend)."""
    chunk: int = Field(64, ge=1)
    """Samples per task: one dask task writes one zarr shard per array (64 like render.chunk: docs/CODECS.md)."""

    @model_validator(mode="after")
    def _alpha_order(self) -> "BlendConfig":
        if self.alpha_low > self.alpha_high:
            raise ValueError(f"need alpha_low <= alpha_high, got {self.alpha_low} > {self.alpha_high}")
        return self


class StressConfig(StageConfig):
    """`svgen stress`: the failure-case evaluation sets (paper §6)."""

    SECTION: ClassVar[str] = "stress"
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {"default": {}, "tiny": {"per_category": 1, "size": 64}}

    per_category: int = Field(8, ge=1)
    """SVBRDFs per category."""
    size: int = Field(256, ge=MIN_SIZE, le=MAX_SIZE)
    """Map resolution (square; the material generators' range, any integer in it)."""
    seed: int = Field(0, ge=0, lt=2 ** 64)
    """Master seed; sample j of category C uses derive_seed(seed, "stress", crc32(C), j)."""
    categories: tuple[str, ...] = Field((), **_LIST)
    """Only these categories (empty: all of pipeline.stress.CATEGORIES)."""
    chunk: int = Field(4, ge=1)
    """Samples per task: one dask task writes one zarr shard per array (a small evaluation set: few objects
    whatever the task)."""


#: light models and pixel samplers of the flash scene (pipeline/render/scene.py holds the implementations; a
#: test holds these names to its LIGHT_MODELS and SAMPLERS, so the config can be read without loading mitsuba).
LightModel = Literal["point", "sphere"]
Sampler = Literal["centre", "stratified", "independent"]
#: the Mitsuba variants svgen renders in (svcore.mi_env.VARIANTS; a test holds them equal)
MitsubaVariant = Literal["llvm_ad_rgb", "cuda_ad_rgb"]


class RenderConfig(StageConfig):
    """`svgen render`: flash photographs of every SVBRDF of a variants, blends or stress store."""

    SECTION: ClassVar[str] = "render"
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "default": {}, "tiny": {"views": 2, "res": 64, "chunk": 2},
        "paper": {"views": 10, "res": 288, "maps": "inputs"}}

    views: int = Field(10, ge=1)
    """Views per SVBRDF (the paper: 10), each with its own light offset, zoom, rotation, shift and seed."""
    res: int = Field(256, ge=16, le=2048)
    """Render resolution (square, 16..2048); the paper renders 288 and crops 256 at training time."""
    zoom: tuple[float, float] = Field((0.7, 1.4), **_LIST)
    """Range of the per-view texture zoom (base-map tiles across the picture width, log-uniform; min == max: one
    zoom for every view). At the default it is left out of the recorded config (the same bytes as before the
    key)."""
    spp: int = Field(1, ge=1)
    """Samples per pixel (the default 1 shades the pixel centre; its error against a converged reference:
    docs/PERFORMANCE.md)."""
    light: LightModel = "point"
    """Flash model: point, or sphere (radius 0.02, the paper's light)."""
    sampler: Sampler = "centre"
    """Pixel sampling: centre (deterministic pixel centres; spp a square), stratified, independent."""
    seed: int = Field(0, ge=0, lt=2 ** 64)
    """Master seed; view k of SVBRDF s uses derive_seed(seed, "render", s, k)."""
    chunk: int = Field(64, ge=1)
    """SVBRDFs per task: one dask task renders chunk * views images and writes one zarr shard per array (the
    store's objects, the resume unit; 64: <= 200 objects per 10,000 views, docs/CODECS.md)."""
    variant: MitsubaVariant = "llvm_ad_rgb"
    """Mitsuba variant that renders: llvm_ad_rgb (the CPU) or cuda_ad_rgb (an NVIDIA GPU; refused where drjit finds
    no CUDA driver). The same scene and BSDF, named in the store's attributes; left out of the recorded config at the
    default (the same bytes as before the key), so a cuda_ad_rgb store has a config hash of its own: CUDA's
    arithmetic need not match LLVM's bit for bit (docs/GPU.md)."""

    maps: Literal["stored", "inputs"] = "stored"
    """stored: copy each SVBRDF's base maps into the renders store (a self-contained store, to move, upload or
    publish alone; format version 4; left out of the recorded config, the same bytes as before the key). inputs (the
    paper preset's): store no maps; readers read SVBRDF s's from the input store it records (sample ``source[s]`` of
    ``inputs[input[s]]``; a recipe blends store mixes them from its variants store), checked against the inputs'
    config hashes, sizes and seeds: the same codes, without the paper scale's 22 GB of copies (format version 6);
    keep the inputs beside it."""
    views_per_launch: int = Field(1, ge=1)
    """Views of one SVBRDF rendered by one Mitsuba call (point flash only; at most ``views`` are used). 1 renders
    each view on its own. More shares the call's fixed cost (tracing the Python integrator and BSDF, the launch):
    for GPUs, where that cost dominates; on a CPU it is faster only at small resolutions (docs/GPU.md). The images
    equal one view per call up to the float rounding of the pixel positions on the wider film (one 8-bit code on a
    few pixels per million); left out of the recorded config at 1 (the same bytes as before the key), so a store
    records a larger value and is resumed only under it."""

    #: the default zoom range (pipeline.render.views.ZOOM_MIN, ZOOM_MAX; a test holds them equal)
    DEFAULT_ZOOM: ClassVar[tuple[float, float]] = (0.7, 1.4)

    @model_validator(mode="after")
    def _square_spp(self) -> "RenderConfig":
        if self.sampler != "independent" and math.isqrt(self.spp) ** 2 != self.spp:
            raise ValueError(f"sampler {self.sampler!r} needs a square spp (1, 4, 9 ...), got {self.spp}")
        if self.views_per_launch > 1 and self.light != "point":
            raise ValueError(f"views_per_launch {self.views_per_launch} needs the point flash: the sphere flash is "
                             f"rendered by Mitsuba's 'direct' integrator, one flash per scene")
        if len(self.zoom) != 2 or not 0.125 <= self.zoom[0] <= self.zoom[1] <= 8:
            raise ValueError(f"zoom must be a range [min, max] with 0.125 <= min <= max <= 8 (tiles across the "
                             f"picture), got {list(self.zoom)}")
        return self

    def dropped_keys(self) -> tuple[str, ...]:
        """Keys left out of the recorded config because they are at their default (same bytes as before)."""
        return (("zoom",) if tuple(self.zoom) == self.DEFAULT_ZOOM else ()) + \
            (("variant",) if self.variant == "llvm_ad_rgb" else ()) + \
            (("views_per_launch",) if self.views_per_launch == 1 else ()) + \
            (("maps",) if self.maps == "stored" else ())


#: the importer's layouts (pipeline.importer.layouts.LAYOUTS, a test holds them equal) and "auto"
ImportLayout = Literal["auto", "folders", "deschaintre", "matsynth"]
NormalConvention = Literal["auto", "opengl", "directx"]


class ImportConfig(StageConfig):
    """`svgen import`: material folders or 2018 strips -> a variants store (or a renders store)."""

    SECTION: ClassVar[str] = "import"
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {"default": {}, "tiny": {"size": 64, "chunk": 2}}

    sources: tuple[str, ...] = Field((), **_LIST)
    """Source folders (a material folder, a tree of them, or a folder of 2018 strips); the command's SRC
    arguments replace them. Empty by default, so the default pipeline imports nothing."""
    layout: ImportLayout = "auto"
    """folders (one material per folder of map files), deschaintre (5-tile PNG strips), matsynth (parquet shards
    with `datasets` image columns, one material per row: MatSynth's as published on the Hugging Face hub), or auto
    (matsynth when the sources are .parquet files or folders of them; strips when every image is a PNG 5 times as
    wide as high; else folders)."""
    size: int = Field(256, ge=16, le=4096)
    """Output map side: sources are centre-cropped to a square and area-averaged down to it."""
    normal_convention: NormalConvention = "auto"
    """opengl (y up, DESIGN.md), directx (green flipped), or auto: the file name (NormalGL/NormalDX), else the
    agreement with a height map's gradient, else OpenGL (recorded per material)."""
    category: str = ""
    """Category of materials whose sidecar metadata.json gives none (empty: "imported"); names become
    "<category>/<material>"."""
    allow_upscale: bool = False
    """Permit maps smaller than size (periodic bilinear upsampling); otherwise such materials are refused."""
    as_kind: Literal["variants", "renders"] = "variants"
    """variants: the maps, which svgen render renders again; or renders (deschaintre layout only): the strip's own
    photo as a one-view renders store with the identity view transform, for svtrain eval --store."""
    input_space: Literal["linear", "srgb"] = "linear"
    """Deschaintre layout: how the strip's input photo is encoded (linear: as the 2018 code read it; srgb)."""
    height_strength: float = Field(0.02, gt=0, le=10)
    """Relief of height value 1 in tile widths: height-derived normals are normalize(-s dh/du, -s dh/dv, 1)."""
    crop: float = Field(1.0, gt=0, le=1)
    """Physical scale: the side of the window of the source's centred square that becomes the map, as a fraction
    of that square's side (1: the whole tile; 0.25: a quarter-width window, 1/16 of the area). A capture covers
    10-30 cm of material, a scanned tile often a metre or more (docs/IMPORT.md "Physical scale")."""
    crop_centre: tuple[float, float] = Field((0.5, 0.5), **_LIST)
    """Where the crop window sits: its centre as (x right, y down) fractions of the square; the window is moved
    inside the square where it would leave it."""
    capture_cm: float | None = Field(None, gt=0, le=10000)
    """Width of material the map should show, in cm, for materials whose metadata.json states physical_size_cm
    (the tile's width): their crop is capture_cm / physical_size_cm (at most 1); the others use crop."""
    chunk: int = Field(4, ge=1)
    """Materials per task: one dask task converts them and writes one zarr shard per array (small: a task holds
    its materials' full-size source maps in memory)."""
    split: str = Field("", pattern=r"^[A-Za-z0-9_]*$")
    """matsynth layout: only the shards of this split, named as the Hugging Face hub names them
    (train-00000-of-00008.parquet, or shards in a folder named train); empty: every shard."""
    only_category: tuple[str, ...] = Field((), **_LIST)
    """Import only materials of these categories (as their metadata names them: MatSynth's wood, metal ...);
    empty: all."""
    limit: int | None = Field(None, ge=1)
    """Import at most this many materials: the first, in source order, that pass every check; null: all."""
    physical_size_unit: Literal["", "m", "cm", "mm"] = ""
    """matsynth layout: the unit of metadata.physical_size, which MatSynth's dataset card does not state. With
    capture_cm, a row's tile width in cm is physical_size in this unit; empty with capture_cm: refused (svgen does
    not guess units)."""

    #: keys added after stores were made, left out of the recorded config at their defaults (same bytes as before)
    LATER_KEYS: ClassVar[tuple[str, ...]] = ("split", "only_category", "limit", "physical_size_unit")

    @model_validator(mode="after")
    def _consistent(self) -> "ImportConfig":
        if "/" in self.category:
            raise ValueError(f"category {self.category!r} must not contain '/'")
        if self.as_kind == "renders" and self.layout in ("folders", "matsynth"):
            raise ValueError(f"--as renders needs the deschaintre layout ({self.layout} hold maps, not photographs)")
        if len(self.crop_centre) != 2 or not all(0 <= c <= 1 for c in self.crop_centre):
            raise ValueError(f"crop_centre must be two fractions in [0, 1] (x, y), got {list(self.crop_centre)}")
        return self

    def dropped_keys(self) -> tuple[str, ...]:
        """Keys left out of the recorded config because they are at their default (same bytes as before)."""
        return tuple(k for k in self.LATER_KEYS if getattr(self, k) == type(self).model_fields[k].default)


class ReferenceConfig(StageConfig):
    """`svgen reference`: real material folders imported and rendered with the training views, the store that
    `svtrain eval-reference` evaluates a run on (the sim-to-real yardstick, issue #21)."""

    SECTION: ClassVar[str] = "reference"
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {"default": {}, "tiny": {"size": 64}}

    sources: tuple[str, ...] = Field((), **_LIST)
    """Folders of real material sets (e.g. ../shared/materials-cc0, ambientCG downloads, MatSynth written out to
    folders). Empty by default: the DVC stages reference and eval_reference then say so and write nothing."""
    size: int = Field(256, ge=16, le=4096)
    """Map side of the imported reference (keep it at sample.size, the training maps' side)."""
    crop: float = Field(1.0, gt=0, le=1)
    """Physical scale of the reference: import.crop of its import (1: whole tiles; 0.5: the centre half-width
    window, the most a 512-pixel source gives at 256 without upscaling; docs/IMPORT.md "Physical scale")."""


#: params.yaml section -> config class of every svgen stage.
STAGE_CONFIGS: dict[str, type[StageConfig]] = {c.SECTION: c for c in (SampleConfig, BlendConfig, StressConfig,
                                                                         RenderConfig, ImportConfig, ReferenceConfig)}
