"""`dvc repro` end to end on a temporary copy of the repository with a tiny parameter set: every stage runs,
metrics and plots are readable, a second `dvc repro` does nothing, and a SIGKILL in the middle of the render
stage followed by `dvc repro` ends with the same bytes as an uninterrupted render."""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from conftest import tree_digest

REPO = Path(__file__).resolve().parents[1]
TINY = {
    "workers": 2,
    "sample": {"per_preset": 1, "size": 64, "seed": 0, "sigma": 0.25, "chunk": 8},
    "blend": {"count": 8, "seed": 0, "alpha_low": 0.2, "alpha_high": 0.8, "mode": "scalar", "chunk": 8},
    "render": {"views": 2, "res": 64, "spp": 1, "light": "point", "sampler": "centre", "seed": 0, "chunk": 2},
    "train": {"preset": "compact", "model": {"base_width": 4, "max_width": 8, "levels": 3},
              "data": {"crop": 32, "workers": 0},
              "optim": {"iterations": 4, "batch_size": 2, "checkpoint_every": 2, "compile_loss": False}},
    "eval": {"limit": 8},
    "stress": {"per_category": 1, "seed": 0},
}
ENV = {**os.environ, "SVGEN_NO_PROGRESS": "1", "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t",
       "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@t"}


def sh(cmd, cwd, check=True, **kw):
    r = subprocess.run(cmd, cwd=cwd, env=ENV, capture_output=True, text=True, shell=isinstance(cmd, str), **kw)
    if check and r.returncode != 0:
        raise AssertionError(f"{cmd} failed ({r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
    return r


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    """A copy of the tracked files of this repository as a fresh git + DVC project with tiny params."""
    if shutil.which("dvc") is None:
        pytest.fail("dvc is not installed: run scripts/setup.sh")
    d = tmp_path_factory.mktemp("proj")
    files = sh(["git", "ls-files"], REPO).stdout.split()
    for f in files:
        if (REPO / f).is_file():
            (d / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(REPO / f, d / f)
    (d / "params.yaml").write_text(yaml.safe_dump(TINY))
    (d / "dvc.lock").unlink(missing_ok=True)
    sh("git init -q && git add -A && git commit -qm init", d)
    return d


def test_repro_runs_every_stage_then_nothing(project):
    r = sh(["dvc", "repro"], project)
    for stage in ("sample", "blend", "render", "fit", "eval", "stress", "eval_stress", "charts"):
        assert f"Running stage '{stage}'" in r.stdout, r.stdout[-2000:]
    for out in ("data/variants.zarr", "data/blends.zarr", "data/renders.zarr", "runs/train/checkpoint.pt",
                "runs/eval/eval.json", "runs/eval/eval.md", "runs/train/loss.csv", "runs/eval_stress/eval.md",
                "runs/charts/chart_render.png"):
        assert (project / out).exists(), out
    metrics = sh(["dvc", "metrics", "show", "--json"], project).stdout
    assert "rerender" in metrics and "eval.json" in metrics
    again = sh(["dvc", "repro"], project)
    assert "Running stage" not in again.stdout, again.stdout
    assert "up to date" in sh(["dvc", "status"], project).stdout


def test_sigkill_during_render_then_repro_gives_the_same_store(project):
    if not (project / "dvc.lock").exists():
        sh(["dvc", "repro"], project)
    params = yaml.safe_load((project / "params.yaml").read_text())
    params["render"]["seed"] = 1
    params["render"]["chunk"] = 1
    (project / "params.yaml").write_text(yaml.safe_dump(params))
    done = project / "data" / "renders.zarr.partial" / ".done"
    proc = subprocess.Popen(["dvc", "repro"], cwd=project, env=ENV, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 300
    while time.time() < deadline and not (done.exists() and len(list(done.iterdir())) >= 3):
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # dvc, svgen and its dask workers: the whole session
    proc.wait()
    assert done.exists(), "the render stage never started"
    assert not (project / "data" / "renders.zarr").exists()

    sh(["dvc", "repro"], project)
    ref = project / "ref.zarr"
    sh([sys.executable, "-c", "from pipeline.cli import main; main()", "render", "data/variants.zarr",
        "data/blends.zarr", str(ref), "--params", "params.yaml", "--workers", "0"], project)
    assert tree_digest(project / "data" / "renders.zarr") == tree_digest(ref)
    assert "up to date" in sh(["dvc", "status"], project).stdout
