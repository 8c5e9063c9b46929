"""Seed derivation: one master seed per stage, every sample's seed a pure function of (master, index).

Uses numpy's SeedSequence spawn keys, so seeds for different indices and
different purposes are statistically independent and never collide by
arithmetic accident (master+index would). Seed 0 is a valid seed: nothing
here tests seeds for truthiness.
"""
from __future__ import annotations

import numpy as np

# Purpose tags keep the streams of different stages apart even with equal master seeds.
PURPOSES = {"sample": 1, "blend": 2, "render": 3, "train": 4, "eval": 5, "stress": 6, "gallery": 7}

#: Named streams inside a purpose: name -> (purpose, first spawn key). The numbers are part of the bytes of
#: every synthetic sample and trained model (tests/data/same_bytes.json holds them): never renumber one; a new
#: stream takes a new name and a number not used in its purpose.
STREAMS: dict[str, tuple[str, int]] = {
    "synthetic.material": ("train", 1),  # look of synthetic material m (its colours, gloss, bump)
    "synthetic.sample": ("train", 2),  # fields of synthetic sample i of material m
    "synthetic.preset_maps": ("train", 3),  # generator seed of synthetic sample i from a materials preset
    "synthetic.light": ("train", 4),  # flash offset of synthetic sample i
    "train.epoch_order": ("train", 5),  # permutation of the training split in epoch e
    "train.augment": ("train", 6),  # crop window, flips and rotation of sample position p
    "train.init": ("train", 100),  # network weights (torch's global RNG at build time)
    "train.loss_configs": ("train", 101),  # the rendering loss's light/view draws (checkpointed generator)
    "train.dropout": ("train", 102),  # torch's global RNG after build: dropout
    "train.loader": ("train", 103),  # the DataLoader's own generator (worker base seeds)
    "train.rank_dropout": ("train", 104),  # dropout of data-parallel rank r >= 1 (rank 0 keeps train.dropout)
    "split.holdout": ("eval", 0),  # which source presets are held out
    "split.folds": ("eval", 1),  # which reference materials fall in which cross-validation fold
    "realism.split_half": ("eval", 21),  # split s of a reference's materials into halves (stats noise floor)
    "predict_sheet.views": ("eval", 30),  # which views benchmarks/bench_predict_sheet.py shows (per store)
    "gallery.sample": ("gallery", 0),  # which SVBRDFs of a store larger than --max the gallery shows
}


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


def stream_seed(master: int, stream: str, *keys: int) -> int:
    """The seed of a named stream (:data:`STREAMS`): ``derive_seed(master, purpose, number, *keys)``."""
    if stream not in STREAMS:
        raise ValueError(f"unknown seed stream {stream!r}; known: {sorted(STREAMS)}")
    purpose, number = STREAMS[stream]
    return derive_seed(master, purpose, number, *keys)


def stream_rng(master: int, stream: str, *keys: int) -> np.random.Generator:
    """A fresh Generator of a named stream (see :func:`stream_seed`)."""
    return np.random.default_rng(stream_seed(master, stream, *keys))
