"""Same inputs, same bytes (issue 40): every file of a store, zarr.json with its CF ``history`` and versions and the
card included, is a function of the seed, the code, the configuration and the inputs; not of the working directory,
the spelling of the paths, the time or the time zone. (DVC hashes these files: a fresh clone's `dvc repro` must
leave dvc.lock as committed; tests/test_dvc_pipeline.py reruns the data stages later to hold that.)"""
from __future__ import annotations

import json
import time
from pathlib import Path

import yaml

from conftest import tree_digest

PRESETS = ["paint/glossy_red", "wood/oak_planks"]
PARAMS = {"sample": {"per_preset": 1, "size": 64, "chunk": 1, "presets": PRESETS},
          "render": {"views": 1, "res": 16, "chunk": 1}}


def _project(root: Path) -> Path:
    """A project folder: params.yaml and an empty data/imported (the DVC pipeline's --from-dir)."""
    (root / "data" / "imported").mkdir(parents=True)
    (root / "params.yaml").write_text(yaml.safe_dump(PARAMS))
    return root


def _metadata(store: Path) -> str:
    """The text of every JSON and markdown file of a store (its zarr.json files, manifest and card)."""
    return "\n".join(p.read_text() for p in sorted(store.rglob("*")) if p.suffix in (".json", ".md"))


def test_two_working_directories_two_spellings_and_two_times_give_the_same_files(tmp_path, monkeypatch,
                                                                                    svgen_cli):
    a, b = _project(tmp_path / "a"), _project(tmp_path / "b")
    elsewhere = tmp_path / "elsewhere" / "deeper"
    elsewhere.mkdir(parents=True)
    # a: relative paths from the project folder, as dvc.yaml spells them
    monkeypatch.chdir(a)
    started = time.time()
    for args in (["sample", "data/v.zarr", "--params", "params.yaml", "--from-dir", "data/imported"],
                 ["render", "data/v.zarr", "data/r.zarr", "--params", "params.yaml"]):
        code, err = svgen_cli(*args, "--workers", "0")
        assert code == 0, err
    # b: absolute, roundabout spellings from another folder, in another time zone, at least a second later
    monkeypatch.chdir(elsewhere)
    monkeypatch.setenv("TZ", "Pacific/Kiritimati")  # UTC+14: another local date for most of the day
    time.tzset()
    time.sleep(max(0.0, started + 1.1 - time.time()))
    for args in (["sample", f"{b}/data/../data/v.zarr", f"--params={b}/params.yaml", "--from-dir",
                  f"{b}/data/imported/"],
                 ["render", f"{b}/data/./v.zarr", str(b / "data" / "r.zarr"), "--params", str(b / "params.yaml")]):
        code, err = svgen_cli(*args, "--workers", "0")
        assert code == 0, err
    monkeypatch.delenv("TZ")
    time.tzset()
    for store in ("v.zarr", "r.zarr"):
        got, want = tree_digest(b / "data" / store), tree_digest(a / "data" / store)
        assert "zarr.json" in want and "README.md" in want
        assert got == want, (store, sorted(k for k in want if got.get(k) != want[k]))
        text = _metadata(a / "data" / store)
        # no place and no time: neither folder, nor today's date (UTC or local), nor the hour
        for absent in (str(tmp_path), time.strftime("%Y-%m-%d", time.gmtime()), time.strftime("%Y-%m-%d"),
                       time.strftime("%Y-%m-%dT%H", time.gmtime())):
            assert absent not in text, (store, absent)
    history = {s: json.loads((a / "data" / s / "zarr.json").read_text())["attributes"]["history"]
               for s in ("v.zarr", "r.zarr")}
    # the command, normalised: the store as OUT, the other paths relative to the store's folder, no worker count
    assert history == {"v.zarr": "svgen sample OUT --params ../params.yaml --from-dir imported",
                       "r.zarr": "svgen render v.zarr OUT --params ../params.yaml"}, history


def test_a_change_outside_the_stage_code_changes_no_byte_and_one_inside_does(tmp_path):
    """A store names its code by the digest of what its stage can import (svcore.versions.closure_digest), which
    is what the stage's DVC deps cover (tests/test_dvc_hygiene.py): an edit to the training code, committed, leaves
    a variants store byte-identical (else every dvc.lock committed after a training change would hold stale store
    hashes, and a fresh clone's `dvc repro` would change them); an edit to the sample stage's code changes it."""
    import os
    import shutil
    import subprocess
    import sys

    root, tree = Path(__file__).resolve().parents[1], tmp_path / "tree"
    for pkg in ("svcore", "storage", "pipeline", "materials", "train"):
        shutil.copytree(root / pkg, tree / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    git = ["git", "-c", "user.name=t", "-c", "user.email=t@t", "-c", "commit.gpgsign=false"]

    def commit() -> None:
        for cmd in (["add", "-A"], ["commit", "-qm", "x"]):
            subprocess.run(git + cmd, cwd=tree, check=True, capture_output=True)

    def sample(name: str) -> dict[str, str]:
        out = tmp_path / name / "v.zarr"
        r = subprocess.run([sys.executable, "-c", "from pipeline.cli import main; main()", "sample", str(out),
                            "--config-preset", "tiny", "--per-preset", "1", "--chunk", "2", "--workers", "0",
                            *(w for p in PRESETS for w in ("--preset", p))], cwd=tree, capture_output=True,
                           text=True, env={**os.environ, "PYTHONPATH": str(tree), "SVGEN_NO_PROGRESS": "1"})
        assert r.returncode == 0, r.stderr[-500:]
        return tree_digest(out)

    subprocess.run(git + ["init", "-q"], cwd=tree, check=True, capture_output=True)
    commit()
    before = sample("before")
    with open(tree / "train" / "net.py", "a") as f:
        f.write("# an edit to the training code\n")
    commit()
    assert sample("train_edited") == before
    with open(tree / "pipeline" / "sample.py", "a") as f:
        f.write("# an edit to the sample stage\n")
    edited = sample("sample_edited")
    assert edited["zarr.json"] != before["zarr.json"]
    assert {k for k in before if edited[k] != before[k]} <= {"zarr.json", "README.md"}  # the recorded code only
