"""`svgen sample OUT --from IMPORTED.zarr --per-material K`: the presets' variants plus K perturbed variants of every
material of imported variants stores, in one variants store (so blend and render mix them freely).

Store order: the presets' variants exactly as `svgen sample` plans them, then the imported materials' variants,
store by store, material by material. Imported variant k of material P uses derive_seed(seed, "sample",
crc32(P), k) -- the presets' rule -- and pipeline.importer.perturb's table. The stage is the sample stage
(:func:`pipeline.sample.sample_stage` with its chunk task); this module only plans the imported part.
"""
from __future__ import annotations

import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from svcore.errors import ConfigError
from svcore.seeds import derive_seed

from .config import SampleConfig
from .runner import Stage
from .sample import _chunk_task, perturb, plan, select_presets
from .store import recorded_path
from .svbrdf_store import SVBRDFStore, array_specs


@dataclass(frozen=True)
class ImportedSpec:
    """Variant k of material ``index`` of imported store ``store`` (its preset name, derived seed)."""

    store: str
    index: int
    preset: str
    k: int
    seed: int

    def make(self, sigma: float, size: int):
        """Maps and parameters of this variant (:func:`make_imported`; the size is the store's)."""
        return make_imported(self, sigma)


def imported_stores(cfg: SampleConfig) -> list[str]:
    """``cfg.from_stores`` then the ``*.zarr`` stores of ``cfg.from_dir`` (sorted; a missing folder adds none)."""
    stores = list(cfg.from_stores)
    if cfg.from_dir is not None and Path(cfg.from_dir).is_dir():
        stores += sorted(str(p) for p in Path(cfg.from_dir).glob("*.zarr"))
    return stores


def plan_imported(stores: list[str], per_material: int, seed: int, size: int) -> tuple[list[ImportedSpec], list]:
    """Specs of every imported variant and the stores' material records.

    Raises:
        StoreError: not a variants store; ConfigError: a map size other than ``size``.
    """
    specs, records = [], []
    for path in stores:
        st = SVBRDFStore(path, "variants")
        if st.size != size:
            raise ConfigError(f"{path} holds {st.size}^2 maps, the sample size is {size}; pass --size {st.size}")
        for i in range(len(st)):
            name = st.source(i)["presets"][0]
            key = zlib.crc32(name.encode())
            specs += [ImportedSpec(str(path), i, name, k, derive_seed(seed, "sample", key, k))
                      for k in range(per_material)]
        records += st.attrs.get("materials", [])
    return specs, records


_STORES: dict[str, SVBRDFStore] = {}


def make_imported(spec: ImportedSpec, sigma: float):
    """Maps and parameters of one imported variant: a pure function of (spec, sigma, the store's bytes)."""
    from .importer.perturb import ImportedPreset, apply

    if spec.store not in _STORES:
        _STORES[spec.store] = SVBRDFStore(spec.store, "variants")
    params = perturb(ImportedPreset, spec.k, sigma, np.random.default_rng(spec.seed))
    return apply(_STORES[spec.store].maps(spec.index), params), params


def sample_from_stage(cfg: SampleConfig, stores: list[str]) -> Stage:
    """The sample stage with the imported stores' variants after the presets' (none with ``cfg.only_from``)."""
    from .importer.perturb import TABLE

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

    def attrs(out: Path) -> dict:  # the imported stores relative to the output's directory (pipeline.store)
        return {**fixed, "imported": {"stores": [recorded_path(s, out) for s in stores], "config_hashes": hashes,
                                      "per_material": cfg.per_material,
                                      "table": {p.name: [p.default, p.low, p.high, p.doc] for p in TABLE}}}

    # the imported stores' identities (config hashes, not how their paths are spelled) are part of the config:
    # resuming against a re-imported store is refused; the path keys are not (#15: paths never in the hash)
    drop = ("from_stores", "from_dir") + (SampleConfig.RELIEF_KEYS if cfg.relief == 0 else ())
    config = {**{k: v for k, v in cfg.as_dict().items() if k not in drop}, "from": hashes}
    return Stage("variants", len(specs), cfg.chunk, array_specs("variants", cfg.size, max_params), config, attrs,
                 _chunk_task, dict(specs=specs, chunk=cfg.chunk, sigma=cfg.sigma, size=cfg.size,
                                   preset_index={n: i for i, n in enumerate(names)}, max_params=max_params,
                                   relief=cfg.relief, relief_cycles=cfg.relief_cycles),
                 desc="sample", unit="variant", inputs=tuple(stores))
