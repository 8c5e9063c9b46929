"""svtrain through its CLI: fit/eval/predict on PNG and EXR, and one-line errors for bad input."""
from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest
from PIL import Image

from svcore.image_io import read_exr, write_exr
from train.cli import svtrain
from svcore.cli import run_cli

SMALL = ["--set", "model.base_width=4", "--set", "model.max_width=8", "--set", "model.levels=3",
         "--set", "data.crop=32", "--set", "data.synthetic_size=40", "--set", "data.synthetic_samples=16",
         "--set", "data.synthetic_materials=4", "--set", "data.holdout=0.5", "--set", "optim.batch_size=2",
         "--workers", "0", "--no-compile"]


def run(*args):
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = run_cli(svtrain, "svtrain", [str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("run")
    code, out, err = run("fit", "--out", d, "--iterations", 3, *SMALL)
    assert code == 0, err
    assert json.loads(out.strip().splitlines()[-1])["step"] == 3
    return d


def test_eval_writes_json_and_table(run_dir, tmp_path):
    code, out, err = run("eval", "--checkpoint", run_dir, "--out", tmp_path)
    assert code == 0, err
    res = json.loads((tmp_path / "eval.json").read_text())
    for m in ("model", "input_as_diffuse", "dataset_mean"):
        assert set(res[m]) == {"rerender", "normal", "diffuse", "roughness", "specular"}
        assert all(np.isfinite(v) and v >= 0 for v in res[m].values())
    for b in ("input_as_diffuse", "dataset_mean"):  # the paired statistics against each baseline, per column
        for c, p in res["paired"][b].items():
            assert p["ci95"][0] <= p["gain"] <= p["ci95"][1], (b, c, p)
            assert p["gain"] == pytest.approx(res[b][c] - res["model"][c], abs=1e-9)
    assert "| model |" in (tmp_path / "eval.md").read_text()
    assert "95 % interval" in (tmp_path / "eval.md").read_text()
    assert (tmp_path / "eval.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert_spec_stats_of_the_views(run_dir, tmp_path, res)


def assert_spec_stats_of_the_views(run_dir, out, res):
    """eval's specular-copy statistics (#39) are the quartiles over the evaluated views (per_view.csv) of the
    model's maps and of the ground truth's, each from its own maps, and eval.md shows both."""
    import csv

    import torch

    from train.checkpoint import load_model
    from train.data import PairDataset, open_source
    from train.spec_stats import quartiles, spec_stats

    model, cfg = load_model(run_dir)
    views = [int(r["view"]) for r in csv.DictReader(open(out / "per_view.csv"))]
    ds = PairDataset(open_source(cfg.data), views, cfg.data.crop, cfg.optim.seed, train=False)
    img, gt = (torch.stack([ds[k][i] for k in range(len(ds))]) for i in (0, 1))
    with torch.no_grad():
        maps = {"model": model.eval()(img), "ground_truth": gt}
    assert set(res["specular_copy"]) == set(maps)
    for who, m in maps.items():
        for stat, values in spec_stats(m).items():
            assert res["specular_copy"][who][stat] == pytest.approx(quartiles(values), abs=1e-6), (who, stat)
    md = (out / "eval.md").read_text()
    assert "| specular-diffuse correlation | specular chroma |" in md and "| ground truth |" in md


def test_predict_png_and_exr(run_dir, tmp_path):
    rng = np.random.default_rng(0)
    img = rng.uniform(0.05, 0.6, (50, 70, 3)).astype(np.float32)
    Image.fromarray(np.round(img * 255).astype(np.uint8)).save(tmp_path / "photo.png")
    write_exr(tmp_path / "photo.exr", img)
    for name in ("photo.png", "photo.exr"):
        out = tmp_path / (name + "_maps")
        code, stdout, err = run("predict", tmp_path / name, "--checkpoint", run_dir, "--out", out, "--size", 32)
        assert code == 0, err
        for m in ("normal", "diffuse", "roughness", "specular"):
            assert Image.open(out / f"{m}.png").size == (32, 32)
            assert read_exr(out / f"{m}.exr").shape == (32, 32, 3)
        assert (out / "rerender.png").is_file()
        n = read_exr(out / "normal.exr")
        np.testing.assert_allclose(np.linalg.norm(n, axis=-1), 1, atol=1e-4)


def test_predict_reads_an_rgba_exr_like_its_rgb(run_dir, tmp_path, caplog):
    """Issue #25 item 10: RGBA is the EXR renderers and editors write most; its alpha is dropped (said when it is
    not opaque) and the prediction equals that of the same RGB image."""
    import logging

    import OpenEXR

    img = np.random.default_rng(1).uniform(0.05, 0.6, (40, 40, 3)).astype(np.float32)
    write_exr(tmp_path / "photo_rgb.exr", img)
    for name, alpha in (("photo_rgba.exr", 1.0), ("photo_alpha.exr", 0.5)):
        rgba = np.concatenate([img, np.full((40, 40, 1), alpha, np.float32)], axis=-1)
        with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                          {"RGBA": rgba}) as f:
            f.write(str(tmp_path / name))
    maps = {}
    for name in ("photo_rgb.exr", "photo_rgba.exr", "photo_alpha.exr"):
        caplog.clear()
        with caplog.at_level(logging.WARNING):
            code, out, err = run("predict", tmp_path / name, "--checkpoint", run_dir, "--out", tmp_path / (name + "_m"),
                                 "--size", 32)
        assert code == 0, err
        said = " ".join(r.getMessage() for r in caplog.records)
        assert ("alpha channel is not opaque" in said) == (name == "photo_alpha.exr"), said
        maps[name] = read_exr(tmp_path / (name + "_m") / "diffuse.exr")
    np.testing.assert_array_equal(maps["photo_rgba.exr"], maps["photo_rgb.exr"])
    np.testing.assert_array_equal(maps["photo_alpha.exr"], maps["photo_rgb.exr"])


def test_a_runs_config_yaml_is_a_params_file_that_reproduces_it(run_dir, tmp_path):
    """Issue #25 item 2: `svtrain fit --params RUN/config.yaml` resolves to exactly the run's config (levels 3 of
    SMALL, not the preset's 7), with nothing said about a missing section; but the loader's worker count, a setting
    of the machine (SVGEN_WORKERS) that a run does not record, so that it changes no byte DVC hashes (issue #40)."""
    saved = (run_dir / "config.yaml").read_text()
    assert "workers:" not in saved  # the run had --workers 0
    code, out, err = run("fit", "--params", run_dir / "config.yaml", "--print-config")
    assert code == 0 and err == "", err
    assert [line for line in out.splitlines() if not line.startswith("    workers: ")] == saved.splitlines()
    assert "levels: 3" in out and "    workers: " in out
    (tmp_path / "other.yaml").write_text("sample:\n  seed: 1\n")  # another command's section only
    code, out, err = run("fit", "--params", tmp_path / "other.yaml", "--print-config")
    assert code == 2 and "has no 'train' section (it has sample)" in err and err.count("\n") == 1, err


def test_plain_resume_refuses_other_data_or_config_and_says_what_changed(run_dir, tmp_path, caplog):
    """Issue #25 item 1: a plain `svtrain fit --out RUN` continues RUN only on the same data and config (more
    iterations allowed); otherwise one line names the change and points to --no-resume. Without a store it says
    that it trains on the synthetic demo source."""
    import logging
    import shutil

    run_ = tmp_path / "run"
    shutil.copytree(run_dir, run_)
    before = {f: (run_ / f).read_text() for f in ("provenance.json", "run.json", "config.yaml")}
    for extra, words in ((["--set", "data.synthetic_seed=5"], "data the synthetic demo source"),
                         (["--set", "optim.lr=0.01"], "optim.lr 0.0005 -> 0.01"),
                         (["--set", "model.levels=2"], "model.levels 3 -> 2")):
        code, out, err = run("fit", "--out", run_, "--iterations", 4, *SMALL, *extra)
        assert code == 2 and words in err and "--no-resume" in err and err.count("\n") == 1, err
        assert {f: (run_ / f).read_text() for f in before} == before  # refused before anything is rewritten
    code, out, err = run("fit", "--out", run_, "--iterations", 4, *SMALL, "--set", "data.synthetic_seed=5",
                         "--no-resume")
    assert code == 0 and json.loads(out.strip().splitlines()[-1])["resumed_from"] is None, err
    with caplog.at_level(logging.WARNING):
        code, out, err = run("fit", "--out", run_, "--iterations", 5, *SMALL, "--set", "data.synthetic_seed=5")
    assert code == 0 and json.loads(out.strip().splitlines()[-1])["resumed_from"] == 4, err
    said = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any("training on the synthetic demo source" in m for m in said), said


def test_png_is_linearised(tmp_path):
    from train.predict import read_photo

    Image.fromarray(np.full((40, 40, 3), 128, np.uint8)).save(tmp_path / "g.png")
    assert read_photo(tmp_path / "g.png")[0, 0, 0] == pytest.approx(0.2158, abs=1e-3)  # sRGB 128 -> linear


@pytest.mark.parametrize("case", ["missing", "not_image", "tiny", "bad_suffix", "no_checkpoint", "bad_config",
                                  "unknown_suite", "unknown_key"])
def test_bad_inputs_one_line(case, run_dir, tmp_path):
    if case == "missing":
        args = ("predict", tmp_path / "nope.png", "--checkpoint", run_dir)
    elif case == "not_image":
        (tmp_path / "x.png").write_text("not a png")
        args = ("predict", tmp_path / "x.png", "--checkpoint", run_dir)
    elif case == "tiny":
        Image.fromarray(np.zeros((8, 300, 3), np.uint8)).save(tmp_path / "t.png")
        args = ("predict", tmp_path / "t.png", "--checkpoint", run_dir)
    elif case == "bad_suffix":
        (tmp_path / "x.tif").write_bytes(b"II*\x00")
        args = ("predict", tmp_path / "x.tif", "--checkpoint", run_dir)
    elif case == "no_checkpoint":
        Image.fromarray(np.zeros((40, 40, 3), np.uint8)).save(tmp_path / "ok.png")
        args = ("predict", tmp_path / "ok.png", "--checkpoint", tmp_path / "none")
    elif case == "bad_config":
        args = ("fit", "--out", tmp_path, "--set", "model.levels=x")
    elif case == "unknown_suite":
        args = ("eval", "--checkpoint", run_dir, "--suite", "nonsense")
    else:
        args = ("fit", "--out", tmp_path, "--set", "model.nope=1")
    code, out, err = run(*args)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("svtrain: error:"), err
    assert "Traceback" not in err
