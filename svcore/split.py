"""The held-out split by source material: one rule, shared by the renders store (which records it) and training
(which reads it back, or computes it for a store that predates the record).

A sample may come from several base materials (a blend has two). A fraction of the distinct names is held out;
a sample is in the test split when all its names are held out, in the train split when none is, and dropped
when it mixes both, so no material is seen on both sides.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .errors import StoreError
from .seeds import stream_rng

#: the split a renders store records: training's defaults (train config ``data.holdout`` and ``data.split_seed``).
DEFAULT_HOLDOUT = 0.1
DEFAULT_SEED = 0
RULE = ("held out by base material: a sample is 'test' when all its materials are held out, 'train' when none is, "
        "and dropped when it mixes both")


def held_out_names(ids: Sequence[tuple[str, ...]], holdout: float, seed: int) -> list[str]:
    """The sorted material names held out: ``round(holdout * names)`` of them (at least 1, all but one at most),
    the first of a permutation drawn from the ``split.holdout`` stream of ``seed``.

    Raises:
        StoreError: fewer than 2 distinct names.
    """
    names = sorted({n for t in ids for n in t})
    if len(names) < 2:
        raise StoreError(f"the held-out split needs at least 2 source presets, the source has {len(names)}")
    rng = stream_rng(seed, "split.holdout")
    n_test = min(len(names) - 1, max(1, int(round(holdout * len(names)))))
    return sorted(rng.permutation(names)[:n_test].tolist())


def split_indices(ids: Sequence[tuple[str, ...]], test_names) -> tuple[np.ndarray, np.ndarray]:
    """(train indices, test indices) of samples with material names ``ids`` under :data:`RULE`."""
    test = set(test_names)
    train_idx = [i for i, t in enumerate(ids) if not any(n in test for n in t)]
    # a sample without any material (stress samples: -1 -1) satisfies both rules and is on both sides, as it always
    # was; renders of the default pipeline have none
    test_idx = [i for i, t in enumerate(ids) if all(n in test for n in t)]
    return np.asarray(train_idx, np.int64), np.asarray(test_idx, np.int64)


def split_record(ids: Sequence[tuple[str, ...]], unit: str, holdout: float = DEFAULT_HOLDOUT,
                 seed: int = DEFAULT_SEED) -> dict | None:
    """The split as a store records it (None when there are fewer than 2 materials: nothing to hold out).

    Args:
        ids: material names of every sample, in sample order.
        unit: what one entry of ``ids`` is ("svbrdf": every view of it shares its split).
    """
    try:
        test = held_out_names(ids, holdout, seed)
    except StoreError:
        return None
    tr, te = split_indices(ids, test)
    return {"rule": RULE, "holdout": holdout, "seed": seed, "seed_stream": "split.holdout", "unit": unit,
            "test_materials": test, "counts": {"train": int(len(tr)), "test": int(len(te)),
                                               "dropped": int(len(set(range(len(ids))) - set(tr) - set(te)))}}


def material_folds(names: Sequence[str], k: int, seed: int = DEFAULT_SEED) -> list[list[str]]:
    """``k`` disjoint folds of the distinct material ``names`` for cross-validation over a reference library.

    The names are sorted, permuted by the ``split.folds`` stream of ``seed`` and dealt round-robin, so fold sizes
    differ by at most one and the folds depend on the names alone (not on their order or on the folder they came
    from). A model trained on the materials outside fold ``i`` is evaluated on fold ``i`` only
    (:func:`check_unseen`).

    Returns:
        ``k`` sorted lists of names whose union is the distinct names.

    Raises:
        StoreError: ``k`` < 2 or more folds than names.
    """
    distinct = sorted(set(names))
    if k < 2 or k > len(distinct):
        raise StoreError(f"{k} folds of {len(distinct)} materials: need 2 <= folds <= materials")
    order = stream_rng(seed, "split.folds").permutation(len(distinct))
    return [sorted(distinct[j] for j in order[i::k]) for i in range(k)]


def check_unseen(trained: Sequence[tuple[str, ...]], evaluated: Sequence[str]) -> None:
    """Refuse an evaluation on materials a model was trained on.

    Args:
        trained: the material names of every training sample (a renders store's ``source_presets()``; the
            training split of a store holds a subset of them, so this check is the stricter one).
        evaluated: the material names of the evaluated set.

    Raises:
        StoreError: naming the materials on both sides.
    """
    seen = {n for t in trained for n in t if n}
    both = sorted(seen & {n for n in evaluated if n})
    if both:
        raise StoreError(f"{len(both)} evaluated material(s) were in the training data: {', '.join(both[:5])}"
                         + (" ..." if len(both) > 5 else ""))
