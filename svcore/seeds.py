"""Seed derivation: one master seed per stage, every sample's seed a pure function of (master, index).

Uses numpy's SeedSequence spawn keys, so seeds for different indices and
different purposes are statistically independent and never collide by
arithmetic accident (master+index would). Seed 0 is a valid seed: nothing
here tests seeds for truthiness.
"""
from __future__ import annotations

import numpy as np

# Purpose tags keep the streams of different stages apart even with equal master seeds.
PURPOSES = {"sample": 1, "blend": 2, "render": 3, "train": 4, "eval": 5, "stress": 6}


def derive_seed(master: int, purpose: str, *keys: int) -> int:
    """Return a 63-bit seed for ``(master, purpose, *keys)``.

    Args:
        master: the stage's master seed (any non-negative int; 0 is valid).
        purpose: one of :data:`PURPOSES`.
        *keys: e.g. the sample index, view index.
    """
    if purpose not in PURPOSES:
        raise ValueError(f"unknown seed purpose {purpose!r}; known: {sorted(PURPOSES)}")
    if master < 0 or any(k < 0 for k in keys):
        raise ValueError("seeds and indices must be non-negative")
    ss = np.random.SeedSequence(int(master), spawn_key=(PURPOSES[purpose], *map(int, keys)))
    return int(ss.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))


def rng_for(master: int, purpose: str, *keys: int) -> np.random.Generator:
    """A fresh Generator for ``(master, purpose, *keys)`` (never share one across samples)."""
    return np.random.default_rng(derive_seed(master, purpose, *keys))
