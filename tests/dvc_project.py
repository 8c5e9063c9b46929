"""A temporary copy of this repository as a git + DVC project with tiny params, for the tests that run `dvc repro`.

One such project, brought up to date by one `dvc repro`, is shared by the DVC tests of a session (the
``tiny_dvc_project`` fixture in conftest.py): a tiny repro costs about 80 s on 2 cores, and test_dvc_pipeline and
test_dvc_hygiene each made their own. Tests that change the project (params, a killed stage, an experiment) work on
a copy of it (:func:`clone_project`), so that the shared one stays as the repro left it whatever runs first.
"""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

from svcore.config import merge  # noqa: F401  (the tests that change params merge with it too)

REPO = Path(__file__).resolve().parents[1]
#: 4 of the library's classes (28 presets): the DVC mechanics need a few materials, not the library (the whole
#: library, 182 presets, made every repro and each kill's reruns spend most of their time on sample and render)
TINY_CLASSES = ["fabric", "metal", "stone", "wood"]
TINY = {
    "sample": {"per_preset": 1, "size": 64, "seed": 0, "sigma": 0.25, "chunk": 8, "classes": TINY_CLASSES},
    "blend": {"count": 8, "seed": 0, "alpha_low": 0.2, "alpha_high": 0.8, "mode": "scalar", "chunk": 8},
    "render": {"views": 2, "res": 64, "spp": 1, "light": "point", "sampler": "centre", "seed": 0, "chunk": 2},
    "train": {"config_preset": "compact", "model": {"base_width": 4, "max_width": 8, "levels": 3},
              "data": {"crop": 32, "workers": 0},
              "optim": {"iterations": 4, "batch_size": 2, "checkpoint_every": 2, "compile_loss": False,
                        "log_every": 1}},  # log_every: a training curve of several points
    "eval": {"limit": 8, "extra_stores": []},
    "stress": {"per_category": 1, "size": 64, "seed": 0},
    "import": {"sources": []},
    "reference": {"sources": []},
}
ENV = {**os.environ, "SVGEN_NO_PROGRESS": "1", "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t",
       "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@t"}
#: the stages in this process, without dask workers to start: a machine setting, which reruns nothing
FAST = {**ENV, "SVGEN_WORKERS": "0"}


def sh(cmd, cwd, check=True, env=None, **kw):
    r = subprocess.run(cmd, cwd=cwd, env=env or ENV, capture_output=True, text=True, shell=isinstance(cmd, str),
                       **kw)
    if check and r.returncode != 0:
        raise AssertionError(f"{cmd} failed ({r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
    return r


def copy_project(d: Path, params: dict | None = None) -> Path:
    """The tracked files of this repository copied into ``d`` as a fresh git + DVC project: the repository's
    params.yaml with :data:`TINY` merged in, or ``params`` as the whole file."""
    if shutil.which("dvc") is None:
        pytest.fail("dvc is not installed: run scripts/setup.sh")
    for f in sh(["git", "ls-files"], REPO).stdout.split():
        if (REPO / f).is_file():
            (d / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(REPO / f, d / f)
    if params is None:
        params = yaml.safe_load((d / "params.yaml").read_text())
        merge(params, TINY)
    (d / "params.yaml").write_text(yaml.safe_dump(params, sort_keys=False))
    (d / "dvc.lock").unlink(missing_ok=True)
    sh("git init -q && git add -A && git commit -qm init", d)
    return d


def clone_project(src: Path, dst: Path) -> Path:
    """A copy of a project with its git history, DVC cache, lock and outputs (up to date where ``src`` is)."""
    shutil.copytree(src, dst, symlinks=True)
    return dst
