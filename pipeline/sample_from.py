"""`svgen sample OUT --from IMPORTED.zarr --per-material K`: the presets' variants plus K perturbed variants of every
material of imported variants stores, in one variants store (so blend and render mix them freely).

Store order: the presets' variants exactly as `svgen sample` plans them, then the imported materials' variants,
store by store, material by material. Imported variant k of material P uses derive_seed(seed, "sample",
crc32(P), k) -- the presets' rule -- and pipeline.importer.perturb's table. The stage is the sample stage
(:func:`pipeline.sample.sample_stage` with its chunk task, which composes this plan with the presets'); this
module only plans the imported part.
"""
from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import ClassVar
from pathlib import Path

import numpy as np

from materials.params import perturb

from svcore.errors import ConfigError
from svcore.seeds import derive_seed

from storage.svbrdf_store import SVBRDFStore

from .config import SampleConfig


@dataclass(frozen=True)
class ImportedSpec:
    """Variant k of material ``index`` of imported store ``store`` (its preset name, derived seed)."""

    #: no relief modes: an imported material's relief is measured, not a generator's guess (variant 0 is the
    #: material itself)
    relief_modes: ClassVar[bool] = False
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
