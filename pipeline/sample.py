"""`svgen sample`: perturbed variants of every base material, written to a variants store.

Perturbation (documented distribution): variant 0 of each preset is the
preset's defaults; variant k >= 1 draws every exposed parameter independently
from Normal(default, sigma * (high - low)) truncated to [low, high] (int
parameters are rounded afterwards). The variant's generator seed and its
perturbation come from one derived seed, derive_seed(master, "sample",
crc32(preset name), k): a variant does not change when other presets are
added or removed.

Relief modes (#22, :class:`Relief`): after the generator, a share of the variants (``flat_share``, variant 0
included) gets flat normals and another (``swap_share``) an independent random height field in place of its own
relief, each variant's mode drawn from its own seed; colour, specular and roughness stay the generator's. A
network then cannot read relief from colour texture alone, which made models paint relief onto flat real
materials (experiments/shape/bench_shape_finetune.py). Imported materials' variants keep their measured relief
(``relief_modes`` of their spec).
"""
from __future__ import annotations

import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

import materials
from materials.heights import independent_relief, slope_rms
from materials.noise import add_height, band_field, band_relief
from materials.params import perturb

from svcore.errors import ConfigError
from svcore.seeds import derive_seed

from storage.bounds import check_store_size
from storage.store import recorded_path, write_chunk
from storage.svbrdf_store import SVBRDFStore, array_specs, encode_row

from .config import SampleConfig
from .exec.runner import Stage
from .importer.perturb import TABLE
from .sample_from import imported_stores, plan_imported



@dataclass(frozen=True)
class VariantSpec:
    """One variant to make: preset, index within the preset, derived seed."""

    #: the stage's relief modes apply: a generator's relief follows its colour fields (:class:`Relief`)
    relief_modes: ClassVar[bool] = True
    preset: str
    k: int
    seed: int

    def make(self, sigma: float, size: int) -> tuple[materials.SVBRDF, dict[str, float]]:
        """Maps and parameters of this variant (:func:`make_variant`)."""
        return make_variant(self, sigma, size)


def select_presets(cfg: SampleConfig) -> list[materials.Preset]:
    """The presets a config asks for (all by default), sorted by name. Unknown names raise UnknownMaterial."""
    for c in cfg.classes:
        materials.get_class(c)
    chosen = [materials.get_preset(n) for n in cfg.presets] if cfg.presets else materials.presets()
    if cfg.classes:
        chosen = [p for p in chosen if p.cls in cfg.classes]
    if not chosen:
        raise ConfigError("no preset matches the --preset/--class selection")
    return sorted({p.name: p for p in chosen}.values(), key=lambda p: p.name)


class Plan(Sequence):
    """Every variant of the stage, in store order (preset by preset), made on demand: variant ``i`` is
    ``VariantSpec(names[i // per_preset], i % per_preset, derive_seed(seed, "sample", crc32(name), k))``.

    A few numbers instead of a list: a million-variant stage would otherwise build (and ship to every dask task)
    a list of a million specs before its progress bar could appear.
    """

    def __init__(self, names: list[str], per_preset: int, seed: int):
        self.names, self.per_preset, self.seed = tuple(names), int(per_preset), int(seed)
        self.keys = tuple(zlib.crc32(n.encode()) for n in self.names)

    def __len__(self) -> int:
        return len(self.names) * self.per_preset

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        if i < 0:
            i += len(self)
        if not 0 <= i < len(self):
            raise IndexError(i)
        p, k = divmod(i, self.per_preset)
        return VariantSpec(self.names[p], k, derive_seed(self.seed, "sample", self.keys[p], k))


def plan(cfg: SampleConfig) -> Plan:
    """Every variant of the stage, in store order (preset by preset): a :class:`Plan`."""
    return Plan([p.name for p in select_presets(cfg)], cfg.per_preset, cfg.seed)


def make_variant(spec: VariantSpec, sigma: float, size: int) -> tuple[materials.SVBRDF, dict[str, float]]:
    """Maps and parameters of one variant: a pure function of (spec, sigma, size) and the code."""
    preset = materials.get_preset(spec.preset)
    rng = np.random.default_rng(spec.seed)
    params = perturb(preset, spec.k, sigma, rng)
    # the maps get their own seed, the next draw of the variant's stream: Preset.generate takes a seed (its
    # contract with the catalogue sheet, stress and tests), and changing this chain would change every store
    map_seed = int(rng.integers(0, 2**63 - 1))
    return preset.generate(params, size, map_seed), params


@dataclass(frozen=True)
class Relief:
    """What the stage does to each variant's relief after the generator (the ``SampleConfig`` keys of the same
    names; all zero: nothing, the variants as their presets make them).

    Attributes:
        relief, relief_cycles: an extra band of relief added to every preset's variant (RMS slope, band centre).
        relief_spread: log-normal spread of that RMS slope across variants (0: ``relief`` for every variant).
        relief_patches: largest log-amplitude modulation of the band within a variant (0: uniform).
        flat_share: share of variants given flat normals (colour, specular and roughness kept).
        swap_share: share of variants whose relief is replaced by an independent height field.
        flat_grain: whether the flat variants get the extra band too (False: they stay flat).
    """

    relief: float = 0.0
    relief_cycles: float = 8.0
    flat_share: float = 0.0
    swap_share: float = 0.0
    relief_spread: float = 0.0
    relief_patches: float = 0.0
    flat_grain: bool = True

    @classmethod
    def of(cls, cfg: SampleConfig) -> "Relief":
        return cls(cfg.relief, cfg.relief_cycles, cfg.flat_share, cfg.swap_share, cfg.relief_spread,
                   cfg.relief_patches, cfg.flat_grain)

    def amplitude(self, seed: int) -> float:
        """The extra relief's RMS slope for the variant of seed ``seed``: ``relief`` x exp(relief_spread x z), z one
        normal draw of its own stream (key 1 << 20 | 3), so that a spread changes nothing else in the variant."""
        if self.relief_spread <= 0:
            return self.relief
        z = np.random.default_rng(derive_seed(seed, "sample", (1 << 20) | 3)).standard_normal()
        return float(self.relief * np.exp(self.relief_spread * z))

    def patchy(self, h: np.ndarray, seed: int) -> np.ndarray:
        """The band ``h`` (H, W) with its amplitude varying over the map: h x exp(p g), g a unit smooth field at 4
        cycles per map and p ~ Uniform(0, relief_patches) (streams 1 << 20 | 4 and | 5), rescaled to h's RMS slope."""
        p = self.relief_patches * np.random.default_rng(derive_seed(seed, "sample", (1 << 20) | 4)).random()
        g = band_field(h.shape[0], derive_seed(seed, "sample", (1 << 20) | 5), 4.0).astype(np.float64)
        out = h * np.exp(p * (g - g.mean()) / max(float(g.std()), 1e-12))
        return (out * (slope_rms(h) / max(slope_rms(out.astype(np.float32)), 1e-12))).astype(np.float32)

    def mode(self, seed: int) -> str:
        """"flat", "independent" or "own" for the variant of seed ``seed``: one uniform draw of its own stream
        (key 1 << 20 | 1: no index of the sample stream reaches it), so the rest of the variant is unchanged."""
        if self.flat_share <= 0 and self.swap_share <= 0:
            return "own"
        u = np.random.default_rng(derive_seed(seed, "sample", (1 << 20) | 1)).random()
        return "flat" if u < self.flat_share else "independent" if u < self.flat_share + self.swap_share else "own"

    def apply(self, m: materials.SVBRDF, seed: int, modes: bool = True) -> materials.SVBRDF:
        """``m`` with its relief changed as configured: when ``modes`` (a preset's variant), the relief mode of
        :meth:`mode`, then the extra band; an imported material's variant (``modes`` False) unchanged."""
        mode = self.mode(seed) if modes else "own"
        if mode != "own":
            flat = np.zeros_like(m.normal)
            flat[..., 2] = 1.0
            h = independent_relief(m.size, derive_seed(seed, "sample", (1 << 20) | 2)) if mode == "independent" \
                else None
            m = materials.SVBRDF(flat if h is None else add_height(flat, h), m.diffuse, m.specular, m.roughness)
        if self.relief <= 0 or not modes or (mode == "flat" and not self.flat_grain):
            return m
        # key 1 << 20: no index of the sample stream reaches it, so the relief draws are independent of the variants
        h = band_relief(m.size, derive_seed(seed, "sample", 1 << 20), self.relief_cycles, self.amplitude(seed))
        if self.relief_patches > 0:
            h = self.patchy(h, seed)
        return materials.SVBRDF(add_height(m.normal, h), m.diffuse, m.specular, m.roughness)


def _chunk_task(c: int, threads: int, *, partial: str, specs: list, chunk: int, sigma: float, size: int,
                preset_index: dict[str, int], max_params: int, relief: Relief = Relief()) -> int:
    """Worker: make the variants of chunk ``c`` and write them (one whole chunk).

    ``specs`` are :class:`VariantSpec` or, with imported stores, :class:`pipeline.sample_from.ImportedSpec`:
    each makes its own maps and parameters (``spec.make(sigma, size)``).
    """
    start, stop = c * chunk, min(len(specs), (c + 1) * chunk)
    n = stop - start
    data: dict[str, np.ndarray] = {}  # the chunk's map arrays, encoded into row by row (no per-sample copies)
    params = np.full((n, max_params), np.nan, np.float32)
    for j, spec in enumerate(specs[start:stop]):
        m, pv = spec.make(sigma, size)
        m = relief.apply(m, spec.seed, modes=spec.relief_modes).validate()
        encode_row(data, n, j, m)
        params[j, :len(pv)] = list(pv.values())
    data["params"] = params
    data["seed"] = np.array([s.seed for s in specs[start:stop]], np.uint64)
    data["preset"] = np.array([[preset_index[s.preset], -1] for s in specs[start:stop]], np.int32)
    write_chunk(partial, c, start, data)
    return n


def sample_stage(cfg: SampleConfig) -> Stage:
    """The variants stage of ``cfg`` (validates the selection; writes nothing).

    With imported stores (``from_stores``/``from_dir``) their materials' variants join the presets'
    (:func:`pipeline.sample_from.sample_from_stage`).
    """
    materials.registry.check_size(cfg.size)
    stores = imported_stores(cfg)
    if stores:
        return sample_from_stage(cfg, stores)
    if cfg.only_from:
        raise ConfigError(f"only_from: no imported store in {cfg.from_dir} (and no from_stores)")
    chosen = select_presets(cfg)
    specs = plan(cfg)
    names = [p.name for p in chosen]
    max_params = max(len(p.exposed) for p in chosen)
    attrs = {"presets": names,
             "param_names": {p.name: p.exposed.names() for p in chosen},
             "perturbation": "variant 0 = defaults; else truncnorm(default, sigma*(high-low)) on [low, high]"}
    drop = SampleConfig.IMPORT_KEYS + cfg.dropped_keys()
    config = {k: v for k, v in cfg.as_dict().items() if k not in drop}
    return Stage("variants", len(specs), cfg.chunk, array_specs("variants", cfg.size, max_params), config,
                 attrs, _chunk_task, dict(specs=specs, chunk=cfg.chunk, sigma=cfg.sigma, size=cfg.size,
                                          preset_index={n: i for i, n in enumerate(names)}, max_params=max_params,
                                          relief=Relief.of(cfg)),
                 desc="sample", unit="variant")


def run_sample(out, cfg: SampleConfig, workers: int = 2, scheduler_address: str | None = None) -> str:
    """Write the variants store of ``cfg`` to ``out`` (resuming an interrupted run). Returns the path."""
    # before planning: an astronomically large per_preset is refused in one line, not listed for hours
    materials.registry.check_size(cfg.size)
    if not cfg.only_from:  # (imported stores' variants: the stage's writer checks the whole store)
        chosen = select_presets(cfg)
        check_store_size(out, len(chosen) * cfg.per_preset, cfg.chunk,
                         array_specs("variants", cfg.size, max(len(p.exposed) for p in chosen)))
    return sample_stage(cfg).run(out, workers, scheduler_address)


def sample_from_stage(cfg: SampleConfig, stores: list[str]) -> Stage:
    """The sample stage with the imported stores' variants after the presets' (none with ``cfg.only_from``)."""
    with_presets = not cfg.only_from
    chosen = select_presets(cfg) if with_presets else []
    specs: list = list(plan(cfg)) if with_presets else []
    imported, records = plan_imported(stores, cfg.per_material, cfg.seed, cfg.size)
    names = [p.name for p in chosen] + sorted({s.preset for s in imported}, key=[s.preset for s in imported].index)
    if len(set(names)) != len(names):
        raise ConfigError("an imported material has the name of a preset or of another imported material")
    specs += imported
    max_params = max([len(p.exposed) for p in chosen] + [len(TABLE)])
    fixed = {"presets": names,
             "param_names": {**{p.name: p.exposed.names() for p in chosen},
                             **{s.preset: TABLE.names() for s in imported}},
             "perturbation": "variant 0 = defaults; else truncnorm(default, sigma*(high-low)) on [low, high]",
             "materials": records}
    hashes = [SVBRDFStore(s, "variants").attrs["svgen"]["config_hash"] for s in stores]

    def attrs(out: Path) -> dict:  # the imported stores relative to the output's directory (storage.store)
        return {**fixed, "imported": {"stores": [recorded_path(s, out) for s in stores], "config_hashes": hashes,
                                      "per_material": cfg.per_material,
                                      "table": {p.name: [p.default, p.low, p.high, p.doc] for p in TABLE}}}

    # the imported stores' identities (config hashes, not how their paths are spelled) are part of the config:
    # resuming against a re-imported store is refused; the path keys are not (#15: paths never in the hash)
    drop = ("from_stores", "from_dir") + cfg.dropped_keys()
    config = {**{k: v for k, v in cfg.as_dict().items() if k not in drop}, "from": hashes}
    return Stage("variants", len(specs), cfg.chunk, array_specs("variants", cfg.size, max_params), config, attrs,
                 _chunk_task, dict(specs=specs, chunk=cfg.chunk, sigma=cfg.sigma, size=cfg.size,
                                   preset_index={n: i for i, n in enumerate(names)}, max_params=max_params,
                                   relief=Relief.of(cfg)),
                 desc="sample", unit="variant", inputs=tuple(stores))
