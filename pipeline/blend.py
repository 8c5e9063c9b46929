"""`svgen blend`: alpha-blends of random pairs of variants, written to a blends store.

Blend j draws, from derive_seed(master, "blend", j): a pair (a, b) of distinct
variants uniformly, alpha ~ U(alpha_low, alpha_high), and four mask seeds. The
rule that mixes the pair (maps linearly, normals as slopes, a scalar weight or
a procedural mask per map) is :mod:`materials.blend`.

By default (``maps: recipe``, #42) the store holds each blend's recipe (parents,
alpha, mask seeds) and no maps: readers mix them from the variants store
(:mod:`storage.recipe`), to the codes ``maps: stored`` writes. The stage then
reads no variant at all.
"""
from __future__ import annotations

import numpy as np

from materials import MAP_NAMES, SVBRDF  # noqa: F401  (re-exported for callers of the stage's helpers)
from materials.blend import MIN_NZ, blend_normals, blend_pair, blend_weights, mask  # noqa: F401

from svcore.errors import ConfigError
from svcore.seeds import derive_seed

from storage.store import recorded_path, write_chunk
from storage.svbrdf_store import SVBRDFStore, array_specs, encode_row

from .config import BlendConfig
from .exec.runner import Stage


def draw(j: int, n_variants: int, cfg: BlendConfig) -> dict:
    """Pair, alpha and mask seeds of blend ``j`` (pure function of (cfg.seed, j, n_variants))."""
    seed = derive_seed(cfg.seed, "blend", j)
    rng = np.random.default_rng(seed)
    a, b = (int(x) for x in rng.choice(n_variants, size=2, replace=False))
    alpha = float(rng.uniform(cfg.alpha_low, cfg.alpha_high))
    mask_seeds = [int(s) for s in rng.integers(0, 2**62, size=4)]
    return {"seed": seed, "a": a, "b": b, "alpha": alpha, "mask_seeds": mask_seeds}


def make_blend(src: SVBRDFStore, d: dict, cfg: BlendConfig) -> SVBRDF:
    """The blend described by ``d`` (from :func:`draw`)."""
    w = blend_weights(src.size, d["alpha"], d["mask_seeds"], cfg.mode, cfg.mask_per_map, cfg.mask_scale)
    return blend_pair(src.maps(d["a"]), src.maps(d["b"]), w)


_SOURCES: dict[str, SVBRDFStore] = {}


def _chunk_task(c: int, threads: int, *, partial: str, source: str, cfg: BlendConfig, n_variants: int, n: int,
                presets: np.ndarray) -> int:
    start, stop = c * cfg.chunk, min(n, (c + 1) * cfg.chunk)
    rows = [draw(j, n_variants, cfg) for j in range(start, stop)]
    data: dict[str, np.ndarray] = {}  # the chunk's map arrays (stored mode), encoded into row by row
    if cfg.maps == "stored":
        src = _source(source, 2 * n >= n_variants)
        for j, d in enumerate(rows):
            encode_row(data, stop - start, j, make_blend(src, d, cfg).validate())
    data["seed"] = np.array([r["seed"] for r in rows], np.uint64)
    data["parents"] = np.array([[r["a"], r["b"]] for r in rows], np.int64)
    data["preset"] = np.array([[presets[r["a"]], presets[r["b"]]] for r in rows], np.int32)
    if cfg.maps == "recipe":  # the weight as mixed (float64) and the mask seeds: what a reader mixes from
        data["alpha"] = np.array([r["alpha"] for r in rows], np.float64)
        data["mask_seed"] = np.array([r["mask_seeds"] for r in rows], np.uint64)
    else:
        data["alpha"] = np.array([r["alpha"] for r in rows], np.float32)
    write_chunk(partial, c, start, data)
    return stop - start


def _source(source: str, whole_shards: bool) -> SVBRDFStore:
    """The variants store, opened once per worker process: its chunk cache then serves every task."""
    if source not in _SOURCES:  # once per worker process: its chunk cache then serves every task
        _SOURCES.clear()
        # whole shards where the stage draws at least as many parents as there are variants: most samples of each
        # shard are then read anyway, and one read per shard costs less than one per sample (ChunkCache)
        _SOURCES[source] = SVBRDFStore(source, "variants", whole_shards=whole_shards)
    return _SOURCES[source]


def blend_stage(source, cfg: BlendConfig) -> Stage:
    """The blends stage of ``cfg`` over the variants store ``source`` (opens and checks it; writes nothing)."""
    src = SVBRDFStore(source, "variants")
    if len(src) < 2:
        raise ConfigError(f"{source} has {len(src)} variant(s); blending needs at least 2")
    presets, source_hash = src.presets, src.attrs["svgen"]["config_hash"]
    recipe = cfg.maps == "recipe"

    def attrs(out):  # the source's path relative to the output: the same string for any spelling of it
        # "inputs", as a renders store records its own (a key "source" would be the CF attribute of that name)
        a = {"presets": presets, "inputs": [{"path": recorded_path(source, out), "kind": "variants", "n": len(src),
                                             "config_hash": source_hash}],
             "blend_rule": "maps: w*a + (1-w)*b; normals: slopes n/n_z mixed, renormalised"}
        if recipe:  # what storage.recipe mixes the maps with (materials.blend.blend_weights)
            a["recipe"] = {"mode": cfg.mode, "mask_per_map": cfg.mask_per_map, "mask_scale": cfg.mask_scale,
                           "size": src.size, "maps": "mixed on read from the source variants store "
                                                     "(storage/recipe.py); keep it beside this store"}
        return a

    config = {**cfg.as_dict(), "source_hash": source_hash}  # the source's identity, not its path
    return Stage("blends", cfg.count, cfg.chunk, array_specs("blends", src.size, recipe=recipe), config, attrs,
                 _chunk_task, dict(source=str(source), cfg=cfg, n_variants=len(src), n=cfg.count,
                                   presets=src.preset_table()[:, 0].copy()),
                 desc="blend", unit="blend", inputs=(str(source),))


def run_blend(source, out, cfg: BlendConfig, workers: int = 2, scheduler_address: str | None = None) -> str:
    """Write the blends of ``cfg`` over the variants store ``source`` to ``out``. Returns the path."""
    return blend_stage(source, cfg).run(out, workers, scheduler_address)
