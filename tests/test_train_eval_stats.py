"""The paired model-vs-baseline statistic of ``svtrain eval``: a cluster bootstrap over SVBRDFs."""
from __future__ import annotations

import numpy as np
import pytest

from train.evaluate import cluster_ids, paired


class _Store:
    views = 10


def test_cluster_ids_group_the_views_of_one_svbrdf():
    assert cluster_ids(_Store(), [0, 9, 10, 35]).tolist() == [0, 0, 1, 3]
    assert cluster_ids(object(), [4, 7]).tolist() == [4, 7]  # no notion of SVBRDFs: every view on its own


def test_a_constant_gain_is_found_exactly():
    rng = np.random.default_rng(0)
    base = rng.uniform(0.1, 0.2, 60)
    p = paired(base - 0.01, base, np.arange(60) // 10, seed=0)
    assert p["gain"] == pytest.approx(0.01)
    assert p["ci95"][0] == pytest.approx(0.01) and p["ci95"][1] == pytest.approx(0.01)
    assert p["views_better"] == 1.0 and p["clusters"] == 6


def test_no_gain_gives_an_interval_around_zero():
    """Model and baseline errors drawn from the same distribution: the 95 % interval holds 0 in ~95 % of trials."""
    rng = np.random.default_rng(1)
    covered = 0
    trials = 200
    for t in range(trials):
        a, b = rng.normal(0.1, 0.02, 40), rng.normal(0.1, 0.02, 40)
        lo, hi = paired(a, b, np.arange(40), seed=t, resamples=500)["ci95"]
        covered += lo <= 0.0 <= hi
    # binomial(200, 0.95) has sd 3.1: [170, 200] is a > 4 sd band around 190 (bootstrap intervals run a bit narrow)
    assert 170 <= covered <= 200, covered


def test_correlated_views_widen_the_interval():
    """Ten views of one SVBRDF that share one error are one sample, not ten: grouping them widens the interval."""
    rng = np.random.default_rng(2)
    per_svbrdf = rng.normal(0.0, 0.01, 8)
    diff = np.repeat(per_svbrdf, 10) + rng.normal(0.0, 0.001, 80)
    base = np.full(80, 0.2)
    grouped = paired(base - diff, base, np.arange(80) // 10, seed=0)["ci95"]
    independent = paired(base - diff, base, np.arange(80), seed=0)["ci95"]
    assert grouped[1] - grouped[0] > 2.0 * (independent[1] - independent[0])
