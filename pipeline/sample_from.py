"""`svgen sample OUT --from IMPORTED.zarr --per-material K`: the presets' variants plus K perturbed variants of every
material of imported variants stores, in one variants store (so blend and render mix them freely).

Store order: the presets' variants exactly as `svgen sample` plans them, then the imported materials' variants,
store by store, material by material. Imported variant k of material P uses derive_seed(seed, "sample",
crc32(P), k) -- the presets' rule -- and pipeline.importer.perturb's table.
"""
from __future__ import annotations

import functools
import zlib
from dataclasses import dataclass

import numpy as np

import materials

from .config import SampleConfig, as_dict
from .errors import ConfigError
from .log import get_logger
from .parallel import run_chunks
from .sample import VariantSpec, make_variant, perturb, plan, select_presets
from .seeds import derive_seed
from .store import ArraySpec, StoreWriter, write_chunk
from .svbrdf_store import SVBRDFStore, encode_maps, map_specs

log = get_logger(__name__)


@dataclass(frozen=True)
class ImportedSpec:
    """Variant k of material ``index`` of imported store ``store`` (its preset name, derived seed)."""

    store: str
    index: int
    preset: str
    k: int
    seed: int


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


def _chunk_task(c: int, threads: int, *, partial: str, specs: list, chunk: int, sigma: float, size: int,
                preset_index: dict[str, int], max_params: int) -> int:
    start, stop = c * chunk, min(len(specs), (c + 1) * chunk)
    maps = {k: [] for k in materials.MAP_NAMES}
    params = np.full((stop - start, max_params), np.nan, np.float32)
    for j, spec in enumerate(specs[start:stop]):
        m, pv = make_variant(spec, sigma, size) if isinstance(spec, VariantSpec) else make_imported(spec, sigma)
        for k, v in encode_maps(m.validate()).items():
            maps[k].append(v)
        params[j, :len(pv)] = list(pv.values())
    data = {k: np.stack(v) for k, v in maps.items()}
    data["params"] = params
    data["seed"] = np.array([s.seed for s in specs[start:stop]], np.uint64)
    data["preset"] = np.array([[preset_index[s.preset], -1] for s in specs[start:stop]], np.int32)
    write_chunk(partial, c, start, data)
    return stop - start


def run_sample_from(out, cfg: SampleConfig, stores: list[str], per_material: int, with_presets: bool = True,
                    workers: int = 2, scheduler_address: str | None = None) -> str:
    """Write presets' variants (unless ``with_presets`` is False) and imported variants to ``out``."""
    from .importer.perturb import TABLE

    if per_material < 1:
        raise ConfigError(f"--per-material must be a positive integer, got {per_material}")
    materials.registry.check_size(cfg.size)
    chosen = select_presets(cfg) if with_presets else []
    specs: list = plan(cfg) if with_presets else []
    imported, records = plan_imported(list(stores), per_material, cfg.seed, cfg.size)
    names = [p.name for p in chosen] + sorted({s.preset for s in imported}, key=[s.preset for s in imported].index)
    if len(set(names)) != len(names):
        raise ConfigError("an imported material has the name of a preset or of another imported material")
    specs += imported
    max_params = max([len(p.exposed) for p in chosen] + [len(TABLE)])
    arrays = {**map_specs(cfg.size),
              "params": ArraySpec((max_params,), "float32", "exposed parameters in table order, NaN-padded"),
              "seed": ArraySpec((), "uint64", "derived variant seed"),
              "preset": ArraySpec((2,), "int32", "index into attrs.presets; second column -1")}
    attrs = {"presets": names,
             "param_names": {**{p.name: p.exposed.names() for p in chosen},
                             **{s.preset: TABLE.names() for s in imported}},
             "perturbation": "variant 0 = defaults; else truncnorm(default, sigma*(high-low)) on [low, high]",
             "imported": {"stores": [str(s) for s in stores], "per_material": per_material,
                          "table": {p.name: [p.default, p.low, p.high, p.doc] for p in TABLE}},
             "materials": records}
    ids = [{"path": str(s), "config_hash": SVBRDFStore(s, "variants").attrs["svgen"]["config_hash"]} for s in stores]
    config = {**as_dict(cfg), "from": ids, "per_material": per_material, "with_presets": with_presets}
    with StoreWriter(out, "variants", len(specs), cfg.chunk, arrays, config, attrs) as w:
        done = w.done_samples()
        task = functools.partial(_chunk_task, partial=str(w.partial), specs=specs, chunk=cfg.chunk, sigma=cfg.sigma,
                                 size=cfg.size, preset_index={n: i for i, n in enumerate(names)},
                                 max_params=max_params)
        run_chunks(task, w.pending(), workers=workers, scheduler_address=scheduler_address, desc="sample",
                   unit="variant", total_units=len(specs), done_units=done)
        return str(w.finalize())
