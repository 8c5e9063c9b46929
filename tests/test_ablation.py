"""The ablation grid (benchmarks/ablation.py) through the real `dvc exp run --queue` / `dvc queue start` /
`dvc exp show --json` on a tiny git + DVC project, and the config switches its arms are made of.

The grid test runs 2 cells (the defaults, variants-only training) x 1 training seed for a few steps each: every
cell lands in ablation.json with the config its arm asks for, every experiment is evaluated on the same held-out
views (one split whatever the training seed and data filter), the held-out curve is there, effects are computed.
"""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml

from test_bad_input import call

REPO = Path(__file__).resolve().parents[1]
PRESETS = ["wood/oak_planks", "metal/brushed_steel", "plastic/glossy_blue", "fabric/linen_plain", "stone/slate",
           "paint/glossy_red"]
TINY_TRAIN = {"model.base_width": 4, "model.max_width": 8, "model.levels": 3, "data.crop": 32, "data.workers": 0,
              "data.eval_views": 4, "optim.batch_size": 2, "optim.checkpoint_every": 2, "optim.compile_loss": False}
ENV_GIT = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@t"}


@pytest.fixture(scope="module")
def renders(tmp_path_factory) -> Path:
    """A tiny renders store of variants and blends of 6 presets (in-process, no workers: seconds)."""
    from pipeline.cli import cli

    d = tmp_path_factory.mktemp("ablation_data")
    code, err = call(cli, "svgen", ["sample", d / "variants.zarr", "--config-preset", "tiny", "--per-preset", "2",
                                    "--chunk", "4", "--workers", "0", *[x for p in PRESETS for x in ("--preset", p)]])
    assert code == 0, err
    code, err = call(cli, "svgen", ["blend", d / "variants.zarr", d / "blends.zarr", "--config-preset", "tiny",
                                    "--count", "8", "--workers", "0"])
    assert code == 0, err
    code, err = call(cli, "svgen", ["render", d / "variants.zarr", d / "blends.zarr", d / "renders.zarr",
                                    "--config-preset", "tiny", "--views", "2", "--res", "64", "--workers", "0"])
    assert code == 0, err
    return d / "renders.zarr"


# --- the config switches ------------------------------------------------------------------------------------------

def test_global_track_off_drops_its_parameters_and_still_runs():
    from train.config import ModelConfig
    from train.net import SVBRDFNet, count_parameters

    on, off = (SVBRDFNet(ModelConfig(base_width=4, max_width=16, levels=4, global_track=t)) for t in (True, False))
    assert count_parameters(off) < count_parameters(on)
    assert not any("to_global" in n or "to_bias" in n or n.startswith(("g0", "out_bias")) for n, _ in
                   off.named_parameters())
    with torch.no_grad():
        y = off.eval()(torch.rand(2, 3, 32, 32))
    assert y.shape == (2, 10, 32, 32)  # the track-free path runs; what it computes is checked below


@pytest.mark.parametrize("track", [True, False])
def test_only_the_global_track_feeds_image_statistics_into_the_biases(track):
    """What tells the arms apart in the output of every normalised layer: instance norm zeroes each channel's
    spatial mean, so without the track a layer's output mean is its learned shift, the same for every image;
    with the track it is FC(global vector), which the image's statistics feed (paper §4.2), so two images differ."""
    from train.config import ModelConfig
    from train.net import GlobalConv, SVBRDFNet

    net = SVBRDFNet(ModelConfig(base_width=4, max_width=16, levels=4, global_track=track)).eval()
    means = []
    hooks = [m.register_forward_hook(lambda _m, _i, out: means.append(out[0].mean((2, 3))))
             for m in net.modules() if isinstance(m, GlobalConv)]
    x = torch.rand(2, 3, 32, 32, generator=torch.Generator().manual_seed(0))
    x[1] = x[1] ** 3 * 0.5  # a darker, higher-contrast second image: other global statistics
    with torch.no_grad():
        net(x)
    for h in hooks:
        h.remove()
    assert len(means) > 3
    # per layer, how far the two images' channel means are apart (float32 instance norm: ~1e-7 when equal)
    gap = max(float((m[0] - m[1]).abs().max()) for m in means)
    if track:
        assert gap > 1e-4, f"with the global track the layer biases ignore the image (gap {gap:.2e})"
    else:
        assert gap < 1e-5, f"without the global track a layer's mean still depends on the image (gap {gap:.2e})"


def test_l1_arm_has_no_rendering_term():
    from train.config import OptimConfig
    from train.fit import loss_terms

    g = torch.Generator().manual_seed(0)
    pred, gt = torch.rand(2, 10, 16, 16), torch.rand(2, 10, 16, 16)

    def no_render(*_a, **_k):
        raise AssertionError("the L1 arm rendered")

    l1 = OptimConfig(render_weight=0.0, map_l1=1.0, normal_l2=0.0)
    torch.testing.assert_close(loss_terms(pred, gt, no_render, g, l1), (pred - gt).abs().mean())
    both = OptimConfig(render_weight=1.0, map_l1=0.0, normal_l2=0.0)
    assert float(loss_terms(pred, gt, lambda *a: torch.tensor(7.0), g, both)) == 7.0


def test_every_loss_weight_zero_is_refused_in_one_line():
    from svcore.errors import ConfigError
    from train.config import resolve

    with pytest.raises(ConfigError) as e:
        resolve("compact", None, {"optim.render_weight": 0.0, "optim.map_l1": 0.0, "optim.normal_l2": 0.0})
    assert "every loss weight is 0" in str(e.value) and "\n" not in str(e.value)


def test_variants_only_drops_exactly_the_blends_and_keeps_the_heldout_views(renders):
    from storage.renders_store import RendersReader
    from train.config import resolve
    from train.data import split_for

    src = RendersReader(renders)
    kinds = src.input_kinds_of_views()
    assert {"variants", "blends"} <= set(kinds)
    # 2 of the 6 presets held out: with split seed 0 both sides hold blends (checked below)
    both = resolve("compact", None, {**TINY_TRAIN, "data.store": str(renders), "data.holdout": 0.3}).data
    var = both.model_copy(update={"blends": False})
    tr_b, te_b = split_for(src, both)
    tr_v, te_v = split_for(src, var)
    assert any(kinds[i] == "blends" for i in te_b)  # else the next line would prove nothing about blends
    np.testing.assert_array_equal(te_b, te_v)  # the same held-out views for both arms
    assert set(tr_b) - set(tr_v) == {i for i in tr_b if kinds[i] == "blends"} != set()
    assert set(tr_v) <= set(tr_b) and all(kinds[i] == "variants" for i in tr_v)


def test_split_seed_not_training_seed_chooses_the_split(renders):
    from storage.renders_store import RendersReader
    from train.config import resolve
    from train.data import split_for

    src = RendersReader(renders)
    split = {}
    for seed, split_seed in ((0, 0), (1, 0), (7, 0), (0, 1), (0, 2), (0, 3)):
        cfg = resolve("compact", None, {**TINY_TRAIN, "data.store": str(renders), "optim.seed": seed,
                                        "data.split_seed": split_seed})
        split[seed, split_seed] = tuple(split_for(src, cfg.data)[1])
    assert split[0, 0] == split[1, 0] == split[7, 0]  # training seeds share one held-out set
    assert len({split[0, s] for s in (0, 1, 2, 3)}) > 1  # and the split seed moves it


# --- the grid through DVC's experiments ---------------------------------------------------------------------------

def _sh(cmd, cwd, env):
    r = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, shell=isinstance(cmd, str))
    assert r.returncode == 0, f"{cmd} failed ({r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r


@pytest.fixture(scope="module")
def project(tmp_path_factory, renders):
    """A git + DVC project: this repository's fit and eval stages on a `dvc add`-ed tiny renders store."""
    import os

    if shutil.which("dvc") is None:
        pytest.fail("dvc is not installed: run scripts/setup.sh")
    env = {**os.environ, **ENV_GIT, "SVGEN_NO_PROGRESS": "1"}
    d = tmp_path_factory.mktemp("ablation_proj")
    for f in _sh(["git", "ls-files"], REPO, env).stdout.split():
        if (REPO / f).is_file() and not f.startswith(("tests/", "docs/", "benchmarks/results/")):
            (d / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(REPO / f, d / f)
    stages = yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]
    (d / "dvc.yaml").write_text(yaml.safe_dump({"stages": {k: stages[k] for k in ("fit", "eval")}}, sort_keys=False))
    (d / "dvc.lock").unlink(missing_ok=True)
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    for k, v in TINY_TRAIN.items():
        sec, key = k.split(".")
        params["train"][sec][key] = v
    params["train"]["optim"]["iterations"] = 2
    params["eval"]["limit"] = 16
    (d / "params.yaml").write_text(yaml.safe_dump(params, sort_keys=False))
    (d / "data").mkdir()
    # the renders store and its inputs (the fit and eval stages name them too: a store without maps reads them)
    for name in ("variants.zarr", "blends.zarr", "renders.zarr"):
        shutil.copytree(renders.parent / name, d / "data" / name)
    # the repository ignores data/ (its stages write it); here the stores are `dvc add`-ed inputs: git keeps their .dvc
    gi = d / ".gitignore"
    gi.write_text("".join(line for line in gi.read_text().splitlines(True) if line.strip() != "/data/"))
    _sh("git init -q && dvc add -q data/variants.zarr data/blends.zarr data/renders.zarr && git add -A && "
        "git commit -qm init", d, env)
    return d, env


@pytest.mark.slow  # 2 DVC experiments of 2 stages each: ~40 s quiet, minutes on the shared 2 cores
def test_tiny_grid_through_dvc_experiments(project, renders, monkeypatch):
    from storage.renders_store import RendersReader
    from train.config import resolve
    from train.data import split_for

    d, env = project
    out = d / "ablation.json"
    cmd = [sys.executable, str(REPO / "benchmarks" / "ablation.py"), "--project", str(d), "--design", "ofat",
           "--cells", "default", "data-variants", "--seeds", "2", "--steps", "4", "--points", "2",
           "--targets", "fit", "eval", "--jobs", "2", "--tag", "t", "--out", str(out), "--note", "test"]
    _sh(cmd, d, env)
    res = json.loads(out.read_text())
    assert set(res["cells"]) == {"default", "data-variants"} and not res["failed"]
    views = set()
    for cell, c in res["cells"].items():
        assert set(c["runs"]) == {"2"}, cell
        for seed, r in c["runs"].items():
            p = r["train_params"]
            # the -S overrides reached the experiment: its params and what it trained
            assert p["data"]["blends"] is (cell == "default") and p["optim"]["seed"] == int(seed)
            assert p["optim"]["iterations"] == 4 == r["steps"] and p["data"]["split_seed"] == 0
            assert r["metrics"]["runs/eval/eval_metrics.json"]["model"]["rerender"] > 0
            assert [row["step"] for row in r["heldout_curve"]] == [0, 2, 4] and "dvc exp run --queue" in r["command"]
            # --steps: no calibration, so no CPU axis (an experiment's clock is no DVC output: train/timing.py)
            assert "cpu_s" not in r["heldout_curve"][-1] and r["train_cpu_s"] is None
            views.add(tuple(r["views"]["heldout"]))
    # one held-out set for every cell: the split of split_seed 0, not of the training seed 2 (another preset)
    cfg = resolve("compact", None, {**TINY_TRAIN, "data.store": str(renders)})
    expect = [split_for(RendersReader(renders), cfg.data.model_copy(update={"split_seed": s}))[1][:16].tolist()
              for s in (0, 2)]
    assert expect[0] != expect[1] and views == {tuple(expect[0])}
    fit = {c: res["cells"][c]["runs"]["2"]["metrics"]["runs/train/fit_metrics.json"]["train_samples"]
           for c in res["cells"]}
    assert fit["data-variants"] < fit["default"]  # the variants-only arm trained on fewer samples
    e = res["effects"]["blends"]["suites"]["heldout"]["rerender"]
    assert e["seeds"] == [1, 1] and e["ci95"][0] <= e["mean"] <= e["ci95"][1]
    assert (out.with_suffix(".md")).read_text().count("| blends |") == 1
    monkeypatch.syspath_prepend(str(REPO / "benchmarks"))
    import importlib.util

    spec = importlib.util.spec_from_file_location("chart_ablation", REPO / "experiments/ablation/chart_ablation.py")
    spec.loader.exec_module(chart := importlib.util.module_from_spec(spec))
    plot = chart.plot

    png = plot(out, d / "chart_ablation.png")  # chart 7 from this grid's results alone
    assert png.stat().st_size > 0 and "| blends |" in png.with_suffix(".md").read_text()


# --- eval.extra_stores --------------------------------------------------------------------------------------------

def test_eval_extra_evaluates_every_listed_store_and_nothing_for_none(renders, tmp_path):
    from train.cli import svtrain
    from train.config import resolve
    from train.fit import fit

    fit(resolve("compact", None, {**TINY_TRAIN, "data.store": str(renders), "optim.iterations": 2}), tmp_path / "run",
        resume=False, show_progress=False)
    params = tmp_path / "params.yaml"
    params.write_text(yaml.safe_dump({"eval": {"limit": 6, "extra_stores": [str(renders), str(renders)]}}))
    code, err = call(svtrain, "svtrain", ["eval-extra", "--checkpoint", tmp_path / "run", "--params", params,
                                         "--out", tmp_path / "extra"])
    assert code == 0, err
    table = json.loads((tmp_path / "extra" / "eval_metrics.json").read_text())
    assert list(table) == ["renders", "renders_2"] and table["renders"] == table["renders_2"]
    assert set(table["renders"]) == {"rerender", "normal", "diffuse", "roughness", "specular"}
    rows = (tmp_path / "extra" / "stores" / "renders" / "per_view.csv").read_text().splitlines()
    assert len(rows) == 1 + 6  # header + eval.limit views
    params.write_text(yaml.safe_dump({"eval": {"limit": 6, "extra_stores": []}}))
    code, err = call(svtrain, "svtrain", ["eval-extra", "--checkpoint", tmp_path / "run", "--params", params,
                                         "--out", tmp_path / "none"])
    assert code == 0 and json.loads((tmp_path / "none" / "eval_metrics.json").read_text()) == {}
    params.write_text(yaml.safe_dump({"eval": {"extra_stores": str(renders)}}))  # a string, not a list
    code, err = call(svtrain, "svtrain", ["eval-extra", "--checkpoint", tmp_path / "run", "--params", params,
                                         "--out", tmp_path / "bad"])
    assert code == 2 and len(err.strip().splitlines()) == 1 and "extra_stores must be a list" in err


# --- the held-out curve within a fit ------------------------------------------------------------------------------

def test_heldout_curve_survives_an_interruption(tmp_path):
    """optim.eval_every: rows at 0, every eval_every steps and the end; a run stopped at a checkpoint and resumed
    writes the same heldout.csv as an uninterrupted one, byte for byte (the rows live in the checkpoint, the
    errors are deterministic); the clock at each row (timing.json, written with every checkpoint) continues."""
    import csv

    from train.config import resolve
    from train.fit import fit

    cfg = resolve("compact", None, {**TINY_TRAIN, "data.synthetic_size": 48, "data.synthetic_samples": 24,
                                    "data.synthetic_materials": 6, "optim.iterations": 6, "optim.eval_every": 2})

    def rows(d):
        return list(csv.DictReader(open(d / "heldout.csv")))

    fit(cfg, tmp_path / "a", resume=False, show_progress=False)
    fit(cfg, tmp_path / "b", resume=False, stop_after=4, show_progress=False)
    m = fit(cfg, tmp_path / "b", resume=True, show_progress=False)
    a, b = rows(tmp_path / "a"), rows(tmp_path / "b")
    assert [r["step"] for r in a] == [r["step"] for r in b] == ["0", "2", "4", "6"]
    for ra, rb in zip(a, b):
        assert {k: ra[k] for k in ("rerender", "normal", "diffuse")} == {k: rb[k] for k in ("rerender", "normal",
                                                                                            "diffuse")}
    assert (tmp_path / "a" / "heldout.csv").read_bytes() == (tmp_path / "b" / "heldout.csv").read_bytes()
    times = json.loads((tmp_path / "b" / "timing.json").read_text())["heldout"]
    assert [t["step"] for t in times] == [0, 2, 4, 6]
    cpu = [t["cpu_s"] for t in times]
    assert cpu[0] == 0 and all(x < y for x, y in zip(cpu, cpu[1:])) and m["train_cpu_s"] >= cpu[-1]


# --- the grid's design and its statistics -------------------------------------------------------------------------

def test_designs_and_the_pairs_each_claim_compares(monkeypatch, tmp_path):
    monkeypatch.syspath_prepend(str(REPO / "benchmarks"))
    from ablation import CLAIMS, cells, overrides, pairs_of

    ofat, full = cells("ofat"), cells("full")
    assert len(ofat) == 6 and len(full) == 24
    counts = {c: (len(pairs_of(ofat, *CLAIMS[c])), len(pairs_of(full, *CLAIMS[c]))) for c in CLAIMS}
    assert counts == {"global track": (1, 12), "rendering loss vs L1 on maps": (1, 8), "normal term": (1, 8),
                      "blends": (1, 12), "width 8 vs 16 (#10)": (1, 12)}
    assert overrides(ofat["width-16"])["model.base_width"] == 16
    l1 = overrides(ofat["loss-l1"])
    assert l1["optim.render_weight"] == 0 and l1["optim.map_l1"] > 0 and l1["optim.normal_l2"] == 0
    assert l1["optim.normal_late_loss"] is None  # the late normal term (the compact preset's since #39) off too
    # and the cell, written as `dvc exp run -S` writes it into params.yaml, is the loss it names over the preset
    from ablation import yaml_value
    from train.config import resolve

    optim: dict = {}
    for key, v in l1.items():
        optim.setdefault(key.split(".")[0], {})[key.split(".")[1]] = yaml.safe_load(yaml_value(v))
    (tmp_path / "params.yaml").write_text(yaml.safe_dump({"train": {"config_preset": "compact", **optim}}))
    got = resolve(None, tmp_path / "params.yaml").optim
    assert (got.render_weight, got.map_l1, got.normal_l2, got.normal_late_loss) == (0, 1, 0, None)
    assert overrides(ofat["global-off"])["model.global_track"] is False
    assert overrides(ofat["data-variants"])["data.blends"] is False


def test_effect_of_a_known_shift_and_of_noise(rng, monkeypatch):
    monkeypatch.syspath_prepend(str(REPO / "benchmarks"))
    from ablation_effects import effect

    clusters = np.repeat(np.arange(10), 4)
    one = rng.uniform(0.1, 0.3, size=(1, 40))
    e = effect(one, one + 0.05, clusters)  # one seed each: only the SVBRDFs are resampled, the shift is everywhere
    assert e["mean"] == pytest.approx(0.05) and e["ci95"] == pytest.approx([0.05, 0.05])
    two = np.concatenate([one, one + 0.1])  # two seeds 0.1 apart: their spread must widen the interval
    assert np.diff(effect(two, two + 0.05, clusters)["ci95"])[0] > 0.05
    noisy = effect(rng.uniform(0.1, 0.3, size=(2, 40)), rng.uniform(0.1, 0.3, size=(3, 40)), clusters)  # none
    assert noisy["ci95"][0] < 0 < noisy["ci95"][1] and noisy["seeds"] == [2, 3] and noisy["svbrdfs"] == 10
