"""eval.png draws the paired bootstrap intervals that evaluate computes (train/eval_chart.py)."""
from __future__ import annotations

import copy

import numpy as np
import pytest
from PIL import Image

from train.eval_chart import _interval, plot_eval

COLS = ("rerender", "normal")


def results() -> dict:
    r = {"model": {"rerender": 0.10, "normal": 0.05}, "input_as_diffuse": {"rerender": 0.20, "normal": 0.06},
         "dataset_mean": {"rerender": 0.30, "normal": 0.07}, "samples": 12, "suite": "heldout"}
    r["paired"] = {b: {c: {"gain": r[b][c] - r["model"][c], "ci95": [r[b][c] - r["model"][c] - 0.04,
                                                                      r[b][c] - r["model"][c] + 0.02],
                           "views_better": 0.9, "clusters": 4} for c in COLS}
                   for b in ("input_as_diffuse", "dataset_mean")}
    return r


def test_whiskers_span_model_plus_the_gain_interval():
    groups = {"heldout": results()}
    err = _interval(groups, ["heldout"], "input_as_diffuse", "rerender")
    # bar top 0.20 = model 0.10 + gain 0.10; interval of the gain [0.06, 0.12] -> whisker [0.16, 0.22]
    np.testing.assert_allclose(err[:, 0], [0.04, 0.02])
    assert _interval(groups, ["heldout"], "model", "rerender") is None


def test_the_chart_shows_the_intervals(tmp_path):
    with_ci = results()
    without = copy.deepcopy(with_ci)
    without.pop("paired")
    a = np.asarray(Image.open(plot_eval({"heldout": with_ci}, tmp_path / "a.png", "t")).convert("L"), float)
    b = np.asarray(Image.open(plot_eval({"heldout": without}, tmp_path / "b.png", "t")).convert("L"), float)
    assert a.shape == b.shape
    changed = np.abs(a - b)[:-20] > 40  # the panels, without the note under them (the layout moves by its height)
    if changed.sum() < 50:  # whiskers add dark pixels
        Image.fromarray((np.abs(a - b)).astype(np.uint8)).save(tmp_path / "diff.png")
        pytest.fail(f"the intervals are not drawn: {changed.sum()} pixels differ (diff in {tmp_path})")
