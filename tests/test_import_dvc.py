"""The DVC `import` stage: empty import.sources leaves the variants store byte-identical to plain `svgen sample`;
listed folders join the variants (and so blend and render) through `svgen sample --from-dir data/imported`."""
from __future__ import annotations

import json

from pathlib import Path

import numpy as np
import yaml

from conftest import tree_digest
from import_fixtures import ambientcg, bumpy_normals
from dvc_project import FAST, REPO, copy_project, sh  # the same project copy rules

SAMPLE = {"per_preset": 1, "size": 64, "seed": 0, "sigma": 0.25, "chunk": 8, "presets": ["paint/glossy_red"],
          "per_material": 2}


def project(d, sources):
    """The repository as a git + DVC project (dvc_project.copy_project) with the tiny sample and ``sources``."""
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    params.update({"sample": SAMPLE, "import": {"sources": sources}})
    return copy_project(d, params)


def test_dvc_import_stage(tmp_path):
    from storage.svbrdf_store import SVBRDFStore

    empty = project(tmp_path / "empty", [])
    r = sh(["dvc", "repro", "sample"], empty, env=FAST)
    assert "Running stage 'import'" in r.stdout and "Running stage 'sample'" in r.stdout, r.stdout
    # the reference: the sample stage's own function, without any import code path
    from pipeline.config import SampleConfig
    from pipeline.sample import run_sample
    from svcore.config import build

    ref = run_sample(tmp_path / "ref.zarr", build(SampleConfig, params_file=empty / "params.yaml"), workers=0)
    # the default pipeline is unchanged: every file the same but the metadata's CF history and the card that prints
    # it, which name how each store was made (`svgen sample OUT --params …` by DVC, the Python API for the reference)
    a, b = tree_digest(empty / "data/variants.zarr"), tree_digest(ref)
    meta = ("zarr.json", "README.md")
    assert {k: v for k, v in a.items() if k not in meta} == {k: v for k, v in b.items() if k not in meta}
    attrs = [json.loads((Path(p) / "zarr.json").read_text())["attributes"] for p in (empty / "data/variants.zarr", ref)]
    assert [{k: v for k, v in x.items() if k != "history"} for x in attrs][0] == \
        [{k: v for k, v in x.items() if k != "history"} for x in attrs][1]

    src = tmp_path / "library"
    ambientcg(src, "Rock", 64, np.random.default_rng(0), {"GL": bumpy_normals(64, np.random.default_rng(1))})
    full = project(tmp_path / "full", [str(src)])
    r = sh(["dvc", "repro", "sample"], full, env=FAST)
    v = SVBRDFStore(full / "data/variants.zarr")
    assert v.presets == ["paint/glossy_red", "imported/Rock"] and len(v) == 1 + 2
    assert "up to date" in sh(["dvc", "status", "sample"], full).stdout
