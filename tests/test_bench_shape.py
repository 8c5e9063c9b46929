"""experiments/shape/bench_shape.py round 2: its arms are compared with their own baseline on the common store's views
(paired), a re-rendered store reuses its parent's variants and blends, and round 1 is unchanged."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments" / "shape"))
import bench_shape as bs  # noqa: E402


def _run(arm, normal, flat, ids, steps=600):
    split = {"normal": list(normal), "flat": list(flat), "svbrdf": list(ids),
             **{k: [0.1] * len(ids) for k in ("rerender", "diffuse", "roughness", "specular")}}
    return {"arm": arm, "steps": steps * bs.ARMS[arm][3], "seed": 0, "heldout": split, "train": split}


def test_round_two_arms_pair_with_their_own_baseline():
    rng = np.random.default_rng(0)
    ids = np.repeat(np.arange(20), 4)
    flat = 0.05 + 0.05 * rng.random(80)
    runs = [_run("base", flat * 1.0, flat, ids), _run("now_base", flat * 0.9, flat, ids),
            _run("now_zoom_wide", flat * 0.8, flat, ids), _run("width16", flat * 0.95, flat, ids)]
    s = bs.summarise({"runs": runs}, 600, resamples=200)
    assert s["now_zoom_wide"]["baseline"] == "now_base" and s["width16"]["baseline"] == "base"
    # effects against the right baseline: 0.8 - 0.9 and 0.95 - 1.0, both paired (same views)
    assert abs(s["now_zoom_wide"]["effect"]["mean"] + 0.1) < 1e-9 and s["now_zoom_wide"]["effect"]["paired"]
    assert abs(s["width16"]["effect"]["mean"] + 0.05) < 1e-9 and s["width16"]["effect"]["paired"]
    assert "effect" not in s["now_base"] and "effect" not in s["base"]
    # round 1's data arms on their own stores stay unpaired
    runs.append(_run("relief_mid", flat * 0.9, flat, ids))
    assert not bs.summarise({"runs": runs}, 600, resamples=200)["relief_mid"]["effect"]["paired"]


def test_a_rerendered_store_renders_its_parents_variants_and_blends():
    cmds = bs.build_commands(Path("D"), "now_zw")
    assert cmds == [["svgen", "render", "D/now_v.zarr", "D/now_b.zarr", "D/now_zw_r.zarr", "--views", str(bs.VIEWS),
                     "--set", "zoom=[0.5, 2]"]]
    assert [c[1] for c in bs.build_commands(Path("D"), "now")] == ["sample", "blend", "render"]
    assert all(bs.eval_store_of(a) == "now" for a in bs.ARMS if a.startswith("now_"))
    # --build --only: a re-rendered store's parent is built first, once
    assert bs.with_parents(["now_zw", "now_z1"]) == ["now", "now_zw", "now_z1"]
    assert bs.with_parents(["c4"]) == ["c4"]
