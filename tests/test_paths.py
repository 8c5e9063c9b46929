"""Paths (issue 15): output bytes do not depend on how an input path is spelled, a killed run resumes with the
other spelling, no command writes into or modifies its input, and a run is usable from any working directory."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest

from conftest import tree_digest
from storage.store import partial_path
from test_bad_input import call
from train import checkpoint
from train.cli import svtrain

from test_store_integrity import SMALL_FIT  # noqa: E402

RENDER = ["--config-preset", "tiny", "--views", "1", "--res", "16", "--chunk", "1", "--workers", "0"]
FIT = SMALL_FIT  # the same tiny fit as the integrity tests


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    """A project directory with data/v.zarr (4 variants) and data/r.zarr (its renders)."""
    from pipeline.cli import cli

    d = tmp_path_factory.mktemp("project")
    (d / "data").mkdir()
    code, err = call(cli, "svgen", ["sample", d / "data" / "v.zarr", "--config-preset", "tiny", "--per-preset", "2",
                                    "--chunk", "1", "--workers", "0", "--preset", "paint/glossy_red",
                                    "--preset", "wood/oak_planks"])
    assert code == 0, err
    code, err = call(cli, "svgen", ["render", d / "data" / "v.zarr", d / "data" / "r.zarr", *RENDER])
    assert code == 0, err
    return d


def test_absolute_and_relative_input_spellings_give_identical_bytes(project, tmp_path, monkeypatch, svgen_cli):
    monkeypatch.chdir(project)
    for cmd in (["render", *RENDER], ["blend", "--config-preset", "tiny", "--workers", "0"]):
        code, err = svgen_cli(cmd[0], "data/v.zarr", tmp_path / "rel" / "o.zarr", *cmd[1:])
        assert code == 0, err
        code, err = svgen_cli(cmd[0], project / "data" / ".." / "data" / "v.zarr", tmp_path / "abs" / "o.zarr",
                              *cmd[1:])
        assert code == 0, err
        assert tree_digest(tmp_path / "rel" / "o.zarr") == tree_digest(tmp_path / "abs" / "o.zarr"), cmd[0]
        shutil.rmtree(tmp_path / "rel")
        shutil.rmtree(tmp_path / "abs")


def test_a_killed_run_resumes_with_the_other_spelling(project, tmp_path):
    out = tmp_path / "r.zarr"
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "SVGEN_TEST_KILL_AT": "chunk"}
    cmd = [sys.executable, "-c", "from pipeline.cli import main; main()", "render"]
    r = subprocess.run([*cmd, "data/v.zarr", str(out), *RENDER], cwd=project, env=env, capture_output=True, text=True)
    assert r.returncode == -9 and partial_path(out).exists(), r.stderr  # killed after its first chunk
    env.pop("SVGEN_TEST_KILL_AT")
    r = subprocess.run([*cmd, str(project / "data" / "v.zarr"), str(out), *RENDER], env=env, capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr
    ref = tmp_path / "ref.zarr"
    r = subprocess.run([*cmd, "data/v.zarr", str(ref), *RENDER], cwd=project, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert tree_digest(out) == tree_digest(ref)


def test_no_command_writes_into_or_modifies_its_input(project, tmp_path, svgen_cli):
    v, r = project / "data" / "v.zarr", project / "data" / "r.zarr"
    before = tree_digest(v), tree_digest(r)
    refused = [("render", v, v / "out.zarr", *RENDER), ("render", v, v.parent / "." / "v.zarr" / "x", *RENDER),
               ("blend", v, v / "b.zarr", "--config-preset", "tiny"), ("export", r, r / "png")]
    for args in refused:
        code, err = svgen_cli(*args)
        assert code == 2 and "lies inside input" in err, (args, err)
    for args in (["fit", "--store", r, "--out", r / "run", *FIT],):
        code, err = call(svtrain, "svtrain", args)
        assert code == 2 and "lies inside input" in err, (args, err)
    # and the commands that succeed leave their inputs byte-identical
    assert svgen_cli("render", v, tmp_path / "r2.zarr", *RENDER)[0] == 0
    assert svgen_cli("blend", v, tmp_path / "b.zarr", "--config-preset", "tiny", "--workers", "0")[0] == 0
    assert svgen_cli("export", r, tmp_path / "x", "--format", "png")[0] == 0
    assert call(svtrain, "svtrain", ["fit", "--store", r, "--out", tmp_path / "run", *FIT])[0] == 0
    code, err = call(svtrain, "svtrain", ["eval", "--checkpoint", tmp_path / "run", "--store", r, "--out",
                                          r / "eval"])
    assert code == 2 and "lies inside input" in err, err
    assert call(svtrain, "svtrain", ["eval", "--checkpoint", tmp_path / "run", "--store", r])[0] == 0
    assert (tree_digest(v), tree_digest(r)) == before


def test_eval_finds_the_training_store_from_another_directory(project, tmp_path, monkeypatch):
    monkeypatch.chdir(project)
    code, err = call(svtrain, "svtrain", ["fit", "--store", "data/r.zarr", "--out", "runs/a", *FIT])
    assert code == 0, err
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    code, err = call(svtrain, "svtrain", ["eval", "--checkpoint", project / "runs" / "a", "--store",
                                          project / "data" / "r.zarr", "--out", "e1"])
    assert code == 0, err
    # the run moved without its store: it carries its baselines' training means, so a store evaluates as before
    shutil.copytree(project / "runs" / "a", elsewhere / "moved")
    store = project / "data" / "r.zarr"
    code, err = call(svtrain, "svtrain", ["eval", "--checkpoint", "moved", "--store", store, "--out", "e2"])
    assert code == 0, err
    e1, e2 = (json.loads((elsewhere / e / "eval.json").read_text()) for e in ("e1", "e2"))
    assert e2["train_means"]["from"] == "recorded with the model at fit time"
    assert {k: e2[k] for k in ("model", "input_as_diffuse", "dataset_mean", "train_means")} == \
        {k: e1[k] for k in ("model", "input_as_diffuse", "dataset_mean", "train_means")}
    # its held-out split still needs the training store: one line saying why, and --train-store gives it
    code, err = call(svtrain, "svtrain", ["eval", "--checkpoint", "moved", "--out", "e3"])
    assert code == 2 and "eval needs the run's training store (eval without --store evaluates its held-out " \
                         "split)" in err and "--train-store" in err, err
    assert err.count("\n") == 1
    code, err = call(svtrain, "svtrain", ["eval", "--checkpoint", "moved", "--train-store", store, "--out", "e4"])
    assert code == 0, err
    # a run from before fit recorded the means: one line; --train-store gives them, and they are the recorded ones
    state = checkpoint.load(elsewhere / "moved" / "model.pt")
    del state["provenance"]["train_means"]
    checkpoint.save(elsewhere / "moved" / "model.pt", state)
    code, err = call(svtrain, "svtrain", ["eval", "--checkpoint", "moved", "--store", store, "--out", "e5"])
    assert code == 2 and "records no training means" in err and "--train-store" in err, err
    assert err.count("\n") == 1
    code, err = call(svtrain, "svtrain", ["eval", "--checkpoint", "moved", "--store", store, "--train-store", store,
                                          "--out", "e6"])
    assert code == 0, err
    e6 = json.loads((elsewhere / "e6" / "eval.json").read_text())
    assert e6["train_means"] == {"from": "computed from --train-store", "maps": e2["train_means"]["maps"]}
    assert e6["dataset_mean"] == e2["dataset_mean"] and e6["input_as_diffuse"] == e2["input_as_diffuse"]
