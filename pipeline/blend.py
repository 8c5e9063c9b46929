"""`svgen blend`: alpha-blends of random pairs of variants, written to a blends store.

Blend j draws, from derive_seed(master, "blend", j): a pair (a, b) of distinct
variants uniformly, alpha ~ U(alpha_low, alpha_high), and (mask mode) the mask
seeds. Maps mix linearly, m = w * m_a + (1 - w) * m_b, with w = alpha
(scalar mode, the paper) or a tileable procedural mask in [0, 1] whose
expected mean is alpha (mask mode). Normals mix as slopes: s = (n_x, n_y) / n_z
of each parent mixed linearly, then n = normalize(s_x, s_y, 1). Mixing slopes
is mixing height gradients (what blending two height fields does) and always
gives z > 0; mixing vectors would give a zero vector for opposite normals.
"""
from __future__ import annotations

import numpy as np
from scipy.special import ndtri

from materials import MAP_NAMES, SVBRDF
from materials.maps import normalize
from materials.noise import fbm

from svcore.errors import ConfigError
from svcore.seeds import derive_seed

from storage.store import recorded_path, write_chunk
from storage.svbrdf_store import SVBRDFStore, array_specs, encode_row

from .config import BlendConfig
from .exec.runner import Stage


MIN_NZ = 1e-3  # slopes of normals flatter than this are clamped: keeps n/n_z finite
MASK_EDGE = 0.35  # soft edge of mask transitions, in standard deviations of the mask noise


def blend_normals(na: np.ndarray, nb: np.ndarray, w: np.ndarray | float) -> np.ndarray:
    """Mix two normal maps as slopes.

    Args:
        na, nb: (H, W, 3) unit normals, z > 0.
        w: weight of ``na``: scalar or (H, W, 1).

    Returns:
        (H, W, 3) unit normals with z > 0.
    """
    wa = w[..., 0] if np.ndim(w) == 3 else w
    za, zb = np.maximum(na[..., 2], MIN_NZ), np.maximum(nb[..., 2], MIN_NZ)
    # by channel plane, not (H, W, 2) slices: numpy's inner loop would otherwise run over an axis of length 2
    v = np.empty(na.shape[:-1] + (3,), np.float32)
    for c in range(2):
        v[..., c] = wa * (na[..., c] / za) + (1.0 - wa) * (nb[..., c] / zb)
    v[..., 2] = 1.0
    return normalize(v)


def mask(size: int, seed: int, alpha: float, scale: float) -> np.ndarray:
    """A tileable mask in [0, 1] with expected mean ~alpha: thresholded periodic fBm with soft edges.

    Returns:
        (size, size, 1) float32.
    """
    if alpha <= 0.0 or alpha >= 1.0:
        return np.full((size, size, 1), alpha, np.float32)
    f = fbm(size, seed, 1.0 / scale, beta=3.0)
    f = (f - f.mean()) / max(float(f.std()), 1e-6)
    t = ndtri(1.0 - alpha)  # P(f > t) = alpha for a unit Gaussian field
    return np.clip((f - t) / MASK_EDGE + 0.5, 0.0, 1.0)[..., None].astype(np.float32)


def blend_pair(a: SVBRDF, b: SVBRDF, weights: dict[str, np.ndarray | float]) -> SVBRDF:
    """Blend two SVBRDFs with a weight (scalar or (H, W, 1)) per map."""
    out = {k: np.asarray(weights[k] * getattr(a, k) + (1.0 - weights[k]) * getattr(b, k), np.float32)
           for k in MAP_NAMES if k != "normal"}
    out["normal"] = blend_normals(a.normal, b.normal, weights["normal"])
    return SVBRDF(**out)


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
    a, b = src.maps(d["a"]), src.maps(d["b"])
    if cfg.mode == "scalar":
        w = {k: d["alpha"] for k in MAP_NAMES}
    else:
        seeds = d["mask_seeds"] if cfg.mask_per_map else [d["mask_seeds"][0]] * 4
        w = {k: mask(src.size, s, d["alpha"], cfg.mask_scale) for k, s in zip(MAP_NAMES, seeds)}
    return blend_pair(a, b, w)


_SOURCES: dict[str, SVBRDFStore] = {}


def _chunk_task(c: int, threads: int, *, partial: str, source: str, cfg: BlendConfig, n_variants: int, n: int) -> int:
    if source not in _SOURCES:  # once per worker process: its chunk cache then serves every task
        _SOURCES.clear()
        # whole shards where the stage draws at least as many parents as there are variants: most samples of each
        # shard are then read anyway, and one read per shard costs less than one per sample (ChunkCache)
        _SOURCES[source] = SVBRDFStore(source, "variants", whole_shards=2 * n >= n_variants)
    src = _SOURCES[source]
    start, stop = c * cfg.chunk, min(n, (c + 1) * cfg.chunk)
    data: dict[str, np.ndarray] = {}  # the chunk's map arrays, encoded into row by row (no per-sample copies)
    rows = []
    for j in range(start, stop):
        d = draw(j, n_variants, cfg)
        m = make_blend(src, d, cfg).validate()
        encode_row(data, stop - start, j - start, m)
        rows.append(d)
    pre = src.preset_table()[:, 0]
    data["seed"] = np.array([r["seed"] for r in rows], np.uint64)
    data["parents"] = np.array([[r["a"], r["b"]] for r in rows], np.int64)
    data["preset"] = np.array([[pre[r["a"]], pre[r["b"]]] for r in rows], np.int32)
    data["alpha"] = np.array([r["alpha"] for r in rows], np.float32)
    write_chunk(partial, c, start, data)
    return stop - start


def blend_stage(source, cfg: BlendConfig) -> Stage:
    """The blends stage of ``cfg`` over the variants store ``source`` (opens and checks it; writes nothing)."""
    src = SVBRDFStore(source, "variants")
    if len(src) < 2:
        raise ConfigError(f"{source} has {len(src)} variant(s); blending needs at least 2")
    presets, source_hash = src.presets, src.attrs["svgen"]["config_hash"]

    def attrs(out):  # the source's path relative to the output: the same string for any spelling of it
        return {"presets": presets, "source": {"path": recorded_path(source, out), "config_hash": source_hash,
                                               "n": len(src)},
                "blend_rule": "maps: w*a + (1-w)*b; normals: slopes n/n_z mixed, renormalised"}

    config = {**cfg.as_dict(), "source_hash": source_hash}  # the source's identity, not its path
    return Stage("blends", cfg.count, cfg.chunk, array_specs("blends", src.size), config, attrs, _chunk_task,
                 dict(source=str(source), cfg=cfg, n_variants=len(src), n=cfg.count), desc="blend", unit="blend",
                 inputs=(str(source),))


def run_blend(source, out, cfg: BlendConfig, workers: int = 2, scheduler_address: str | None = None) -> str:
    """Write the blends of ``cfg`` over the variants store ``source`` to ``out``. Returns the path."""
    return blend_stage(source, cfg).run(out, workers, scheduler_address)
