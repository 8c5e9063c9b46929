"""The paper preset (256², base width 64 .. 512, 8 levels, 2 decoder convolutions) starts: 2 steps, then evaluated.

The README's paper-scale recipe is `svtrain fit --config-preset paper`; this runs that config with only the step
count, the batch and the synthetic source made small, so a broken preset (a crop that does not divide by
2^levels, a layer that does not fit at 1x1, a loss that is not finite at 256²) fails here instead of on the
user's GPU.
"""
from __future__ import annotations

import json

import numpy as np

from svcore.cli import run_cli
from train.cli import svtrain
from train.config import preset


def test_paper_preset_two_steps_then_eval(tmp_path, capsys):
    p = preset("paper")
    assert (p.data.crop, p.model.base_width, p.model.max_width, p.model.levels) == (256, 64, 512, 8)
    code = run_cli(svtrain, "svtrain", ["fit", "--config-preset", "paper", "--out", str(tmp_path), "--iterations", "2",
                                        "--batch-size", "2", "--workers", "0", "--no-compile", "--device", "cpu",
                                        "--set", "data.synthetic_samples=8", "--set", "data.synthetic_materials=4",
                                        "--set", "data.holdout=0.5"])
    out, err = capsys.readouterr()
    assert code == 0, err
    m = json.loads(out.strip().splitlines()[-1])
    assert m["step"] == 2 and m["done"] and np.isfinite(m["loss_final"])
    assert m["parameters"] > 50_000_000  # the full-width network, not the compact one
    code = run_cli(svtrain, "svtrain", ["eval", "--checkpoint", str(tmp_path), "--limit", "2"])
    out, err = capsys.readouterr()
    assert code == 0, err
    res = json.loads((tmp_path / "eval.json").read_text())
    assert res["samples"] == 2
    assert all(np.isfinite(v) and v >= 0 for v in res["model"].values())
