"""Evaluation sets where single-image capture is known to fail (paper §6), made from the svgen library.

Each category is a function ``(rng, size) -> (SVBRDF, view overrides)``, registered by name. The view
overrides (e.g. a light far off-centre) are applied by the renderer to every view of that sample.

| category          | what is hard about it (paper §6)                                               |
|-------------------|---------------------------------------------------------------------------------|
| glossy_saturated  | very glossy, bright specular: highlights clip at 1 and hide the roughness      |
| highlight_edge    | the flash highlight at or beyond the image border: little specular cue          |
| print_pattern     | flat, uniform gloss, structured albedo (packaging prints): albedo read as relief |
| dark_albedo       | diffuse albedo <= 0.03: little signal above the noise floor                     |
| bright_albedo     | diffuse albedo >= 0.8: diffuse and specular hard to separate                    |
| decorrelated      | masked blends with a different mask per map: maps that do not share edges       |
| reference         | unmodified variants: the normal test set, for comparison                        |
"""
from __future__ import annotations

import zlib
from typing import Callable

import numpy as np

import materials
from materials import SVBRDF
from materials.noise import Tex, height_to_normal
from materials.params import perturb

from svcore.errors import ConfigError
from svcore.seeds import derive_seed

from storage.bounds import check_store_size
from storage.store import write_chunk
from storage.svbrdf_store import array_specs, encode_maps

from .blend import blend_pair, mask
from .config import StressConfig
from .exec.runner import Stage

Category = Callable[[np.random.Generator, int], tuple[SVBRDF, dict]]
CATEGORIES: dict[str, Category] = {}

#: light offset radius range (world units, camera plane) that puts the mirror highlight at 0.8-1.1 of the
#: image half-width (a flat mirror's highlight sits at half the light offset).
EDGE_LIGHT_RADIUS = (1.6, 2.2)


def category(name: str):
    def deco(fn: Category) -> Category:
        CATEGORIES[name] = fn
        return fn

    return deco


def _variant(rng: np.random.Generator, size: int, classes: tuple[str, ...] = ()) -> SVBRDF:
    pool = [p for p in materials.presets() if not classes or p.cls in classes]
    pre = pool[int(rng.integers(len(pool)))]
    params = perturb(pre, 1, 0.25, rng)
    return pre.generate(params, size, int(rng.integers(0, 2**63 - 1)))


@category("reference")
def reference(rng, size):
    return _variant(rng, size), {}


@category("glossy_saturated")
def glossy_saturated(rng, size):
    m = _variant(rng, size, ("metal", "plastic", "paint", "ceramic_tiles"))
    m.roughness = np.clip(m.roughness * 0.15, 0.02, 0.12).astype(np.float32)
    m.specular = np.clip(np.maximum(m.specular, rng.uniform(0.5, 1.0)), 0, 1).astype(np.float32)
    return m, {}


@category("highlight_edge")
def highlight_edge(rng, size):
    return _variant(rng, size), {"light_radius": EDGE_LIGHT_RADIUS}


@category("print_pattern")
def print_pattern(rng, size):
    """Packaging-like print: stripes, dots and text-like blocks of 2-4 inks on a flat, uniformly glossy sheet."""
    tex = Tex(size, rng)
    inks = rng.uniform(0.02, 0.9, size=(4, 3)).astype(np.float32)
    u, v = tex.u, tex.v
    k = int(rng.integers(3, 9))
    stripes = (np.sin(2 * np.pi * k * (u + 0.3 * v)) > 0).astype(np.float32)
    dots = ((np.sin(2 * np.pi * 2 * k * u) * np.sin(2 * np.pi * 2 * k * v)) > 0.5).astype(np.float32)
    blocks = (tex.fbm(0.05, beta=1.0) > 0.8).astype(np.float32)  # text-like speckle of small marks
    d = inks[0] * np.ones((size, size, 3), np.float32)
    for layer, ink in zip((stripes, dots, blocks), inks[1:]):
        d = np.where(layer[..., None] > 0.5, ink, d)
    flat = height_to_normal(np.zeros((size, size), np.float32))
    r = np.full((size, size, 1), rng.uniform(0.15, 0.5), np.float32)
    s = np.full((size, size, 3), rng.uniform(0.03, 0.08), np.float32)
    return SVBRDF(flat, d.astype(np.float32), s, r), {}


@category("dark_albedo")
def dark_albedo(rng, size):
    m = _variant(rng, size)
    m.diffuse = (m.diffuse / max(float(m.diffuse.max()), 1e-6) * rng.uniform(0.005, 0.03)).astype(np.float32)
    return m, {}


@category("bright_albedo")
def bright_albedo(rng, size):
    m = _variant(rng, size)
    lo = rng.uniform(0.8, 0.9)
    m.diffuse = (lo + (1 - lo) * m.diffuse).astype(np.float32)
    return m, {}


@category("decorrelated")
def decorrelated(rng, size):
    a, b = _variant(rng, size), _variant(rng, size)
    alpha = rng.uniform(0.3, 0.7)
    w = {k: mask(size, int(rng.integers(0, 2**62)), alpha, 4.0) for k in materials.MAP_NAMES}
    return blend_pair(a, b, w), {}


def make(name: str, rng: np.random.Generator, size: int) -> tuple[SVBRDF, dict]:
    """One sample of category ``name`` (validated maps, view overrides)."""
    if name not in CATEGORIES:
        raise ConfigError(f"unknown stress category {name!r}; known: {', '.join(CATEGORIES)}")
    m, over = CATEGORIES[name](rng, size)
    return m.validate(), over


def _chunk_task(c: int, threads: int, *, partial: str, plan: list[tuple[str, int]], chunk: int, size: int,
                categories: list[str]) -> int:
    start, stop = c * chunk, min(len(plan), (c + 1) * chunk)
    maps = {k: [] for k in materials.MAP_NAMES}
    radius, seeds = [], []
    for cat, seed in plan[start:stop]:
        m, over = make(cat, np.random.default_rng(seed), size)
        for k, v in encode_maps(m).items():
            maps[k].append(v)
        radius.append(over.get("light_radius", (np.nan, np.nan)))
        seeds.append(seed)
    data = {k: np.stack(v) for k, v in maps.items()}
    data["seed"] = np.array(seeds, np.uint64)
    data["category"] = np.array([categories.index(cat) for cat, _ in plan[start:stop]], np.int16)
    data["light_radius"] = np.array(radius, np.float32)
    data["preset"] = np.full((stop - start, 2), -1, np.int32)
    write_chunk(partial, c, start, data)
    return stop - start


def _categories(cfg: StressConfig) -> list[str]:
    materials.registry.check_size(cfg.size)
    cats = list(cfg.categories) or list(CATEGORIES)
    for c in cats:
        if c not in CATEGORIES:
            raise ConfigError(f"unknown stress category {c!r}; known: {', '.join(CATEGORIES)}")
    return cats


def stress_stage(cfg: StressConfig) -> Stage:
    """The stress stage of ``cfg``: ``per_category`` SVBRDFs of each category (all by default), kind "stress".

    Sample j of category C is made from derive_seed(seed, "stress", crc32(C), j).
    """
    cats = _categories(cfg)
    plan = [(c, derive_seed(cfg.seed, "stress", zlib.crc32(c.encode()), j)) for c in cats
            for j in range(cfg.per_category)]
    config = {**cfg.as_dict(), "categories": cats}
    attrs = {"categories": cats, "presets": [], "category_docs": {c: (CATEGORIES[c].__doc__ or "").strip() for c in cats}}
    return Stage("stress", len(plan), cfg.chunk, array_specs("stress", cfg.size), config, attrs, _chunk_task,
                 dict(plan=plan, chunk=cfg.chunk, size=cfg.size, categories=cats), desc="stress", unit="svbrdf")


def run_stress(out, cfg: StressConfig, workers: int = 2, scheduler_address: str | None = None) -> str:
    """Write the stress store of ``cfg`` to ``out`` (resuming an interrupted run). Returns the path."""
    # before the plan is listed: an astronomically large per_category is refused in one line
    check_store_size(out, len(_categories(cfg)) * cfg.per_category, cfg.chunk, array_specs("stress", cfg.size))
    return stress_stage(cfg).run(out, workers, scheduler_address)
