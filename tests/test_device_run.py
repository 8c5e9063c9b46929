"""scripts/device_run.sh (issue #44), the prepared GPU run, end to end at a tiny size on this machine: llvm_ad_rgb,
``--device cpu``, no carried wheels. Its first run on a GPU can then fail only on what needs a GPU.

Checked: the files it must write under OUT (the JSON, the log, the compact model), every step ok, the store made in
the asked variant, the llvm comparison exact (llvm against llvm), both fits stopped by the clock with a checkpoint
and steps, and both models evaluated on the held-out views and on the reference store."""
from __future__ import annotations

import json
import os
import signal
import subprocess
from pathlib import Path

import pytest
import torch

from pipeline.config import SampleConfig
from pipeline.sample import run_sample
from svcore.config import build

ROOT = Path(__file__).resolve().parents[1]
TINY = ["--variant", "llvm_ad_rgb", "--device", "cpu", "--per-preset", "2", "--preset", "paint/glossy_red",
        "--preset", "metal/aluminium_plate", "--preset", "wood/oak_planks", "--size", "64", "--views", "2",
        "--res", "128", "--sample-workers", "0", "--render-workers", "0", "--compare", "2", "--compact-s", "4",
        "--paper-s", "4", "--eval-limit", "2", "--loader-workers", "0",
        "--compact-set", "model.base_width=4", "--compact-set", "model.max_width=8",
        # the clock starts at the loss log's first row: after one step here
        "--compact-set", "optim.log_every=1", "--paper-set", "optim.log_every=1",
        # the paper preset's structure, narrower, with 7 levels so that a 128 crop fits
        "--paper-set", "model.base_width=4", "--paper-set", "model.max_width=8", "--paper-set", "model.levels=7",
        "--paper-set", "data.crop=128"]


@pytest.mark.slow
def test_the_prepared_gpu_run_writes_its_json_log_and_model(tmp_path):
    ref = tmp_path / "reference.zarr"
    run_sample(ref, build(SampleConfig, "tiny", presets=("leather/tan_worn",), per_preset=1), workers=0)
    out = tmp_path / "out"
    env = {**os.environ, "SVGEN_DEVICE_WHEELS": str(tmp_path / "no_wheels")}
    # started with SIGINT ignored, as a background job of a non-interactive shell is: the fits must still stop on
    # the clock's Ctrl-C (they inherited the ignore and were killed without a model before device_run restored it)
    r = subprocess.run(["bash", str(ROOT / "scripts" / "device_run.sh"), "--out", str(out), "--work",
                        str(tmp_path / "work"), "--reference", str(ref), *TINY], capture_output=True, text=True,
                       env=env, cwd=tmp_path, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    log = (out / "device_run.log").read_text() if (out / "device_run.log").exists() else ""
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:] + log[-3000:]
    d = json.loads((out / "device_run.json").read_text())
    # seen once without the model under a load of 6-8 on 2 cores (not reproduced with 4 busy loops beside it): say
    # what the compact fit did, and the log's tail, if it happens again
    assert sorted(p.name for p in out.iterdir()) == ["compact_model.pt", "device_run.json", "device_run.log"], (
        json.dumps(d["steps"].get("fit_compact"), indent=1) + "\n" + log[-3000:])
    steps = d["steps"]
    assert list(steps) == ["env", "sample", "render_warmup", "render", "compare", "reference_render", "fit_compact",
                           "eval_compact_train", "eval_compact_heldout", "eval_compact_reference", "fit_paper",
                           "eval_paper_train", "eval_paper_heldout", "eval_paper_reference"]
    assert all(s["ok"] for s in steps.values() if "ok" in s), {k: s for k, s in steps.items() if not s.get("ok")}
    assert steps["render"]["store_variant"] == "llvm_ad_rgb" and steps["render"]["views"] == 12
    assert steps["render"]["views_per_launch"] == 10  # the prepared run's default: an SVBRDF's views per launch
    assert steps["render"]["views_per_s"] > 0
    assert [row["max_abs_code"] for row in steps["compare"]["rows"]] == [0, 0]
    for fit in ("fit_compact", "fit_paper"):
        assert steps[fit]["stopped_by_clock"] and steps[fit]["steps"] >= 1 and steps[fit]["it_per_s"] > 0, steps[fit]
    for ev in ("eval_compact_train", "eval_compact_heldout", "eval_compact_reference", "eval_paper_train",
               "eval_paper_heldout", "eval_paper_reference"):
        assert steps[ev]["metrics"]["model"]["rerender"] >= 0, steps[ev]
    # the train suite evaluated the views the model trained on, not the held-out ones (#39's fit criterion)
    assert "--suite train" in steps["eval_compact_train"]["cmd"], steps["eval_compact_train"]
    model = torch.load(out / "compact_model.pt", weights_only=False)
    assert model["step"] == steps["fit_compact"]["steps"] and model["config"]["model"]["base_width"] == 4
    assert d["paper_model"]["bytes"] > 0 and d["loader"] == {"workers": 0, "env": {}}


def test_carried_llvm_views_compare_only_the_same_svbrdfs_under_the_same_settings(tmp_path):
    """Where the GPU machine has no libLLVM, the cuda store is compared with llvm views made here: only SVBRDFs
    whose maps match, only under the same render settings (each refusal says why)."""
    import sys

    from pipeline.config import RenderConfig
    from pipeline.render.stage import run_render

    sys.path.insert(0, str(ROOT / "scripts"))
    import device_run

    def store(name, seed):
        v = tmp_path / f"{name}_v.zarr"
        run_sample(v, build(SampleConfig, "tiny", presets=("paint/glossy_red",), per_preset=2, seed=seed), workers=0)
        run_render(v, tmp_path / f"{name}.zarr", build(RenderConfig, "tiny"), workers=0)
        return tmp_path / f"{name}.zarr"

    here = device_run.write_llvm_views(store("a", 0), 2, tmp_path / "llvm_views.npz")
    same = device_run.compare_carried(tmp_path / "a.zarr", here)
    assert same["ok"] and [r["max_abs_code"] for r in same["rows"]] == [0, 0] and same["rows"][0]["views"] == 2
    other = device_run.compare_carried(store("b", 1), here)
    assert not other["ok"] and "other SVBRDFs" in other["skipped"]
    import numpy as np

    z = dict(np.load(here))
    np.savez(tmp_path / "views3.npz", **{**z, "config": np.array(str(z["config"]).replace('"views": 2', '"views": 3'))})
    settings = device_run.compare_carried(tmp_path / "a.zarr", tmp_path / "views3.npz")
    assert not settings["ok"] and "rendered with" in settings["skipped"]
