"""The reference renders store (issue #21): `svgen reference` imports real material folders at a stated crop and renders
them with the training views, `svtrain eval-reference` evaluates a run on every view of it. (The DVC stages reference
and eval_reference skipping in one line each when params.yaml reference.sources is empty, the default:
tests/test_dvc_pipeline.py.)"""
from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
import yaml

from dvc_project import REPO

#: the shared CC0 reference folder beside the checkout (../shared/materials-cc0), or SVGEN_REFERENCE_DIR
REFERENCE = Path(os.environ.get("SVGEN_REFERENCE_DIR") or REPO.parent / "shared" / "materials-cc0")


@pytest.fixture
def reference_dir() -> Path:
    if not REFERENCE.is_dir():
        pytest.skip(f"no reference materials at {REFERENCE} (the shared materials-cc0 folder beside the checkout, "
                    "or SVGEN_REFERENCE_DIR)")
    return REFERENCE


def test_tiny_reference_store_and_its_evaluation(reference_dir, tmp_path, svgen_cli):
    from storage.renders_store import RendersReader
    from storage.svbrdf_store import SVBRDFStore
    from test_train_cli import SMALL, run

    names = sorted(p.name for p in reference_dir.iterdir() if p.is_dir())[:2]
    (tmp_path / "p.yaml").write_text(yaml.safe_dump({"render": {"views": 2, "res": 32, "chunk": 2},
                                                     "reference": {"sources": [str(reference_dir / n) for n in names],
                                                                   "size": 64, "crop": 0.5}}))
    code, out = svgen_cli("reference", "--params", tmp_path / "p.yaml", tmp_path / "ref", "--workers", 0)
    assert code == 0, out
    mats = SVBRDFStore(tmp_path / "ref" / "materials.zarr")
    assert [m["name"] for m in mats.attrs["materials"]] == names
    assert all(m["crop"]["fraction"] == 0.5 for m in mats.attrs["materials"])
    assert mats.attrs["import"]["crop"]["fraction"] == 0.5
    r = RendersReader(tmp_path / "ref" / "renders.zarr")
    assert len(r) == 2 * len(names)  # the params file's render section: 2 views of each material
    # a run trained on other data, evaluated on every reference view with its intervals over materials
    code, _, err = run("fit", "--out", tmp_path / "run", "--iterations", 2, *SMALL)
    assert code == 0, err
    code, out, err = run("eval-reference", "--checkpoint", tmp_path / "run", "--params", tmp_path / "p.yaml",
                         "--store", tmp_path / "ref" / "renders.zarr", "--out", tmp_path / "ev")
    assert code == 0, err
    res = json.loads((tmp_path / "ev" / "eval" / "eval.json").read_text())
    assert res["suite"] == "all" and res["samples"] == len(r)
    assert res["paired"]["dataset_mean"]["normal"]["clusters"] == len(names)
    assert "⚠ only 2 SVBRDFs" in (tmp_path / "ev" / "eval" / "eval.md").read_text()
    metrics = json.loads((tmp_path / "ev" / "eval_metrics.json").read_text())
    assert metrics["crop"] == 0.5 and set(metrics["model"]) >= {"normal", "rerender"}


@pytest.mark.parametrize("args, words", [(["EMPTY"], "is empty"), (["--crop", "2"], "reference.crop must be <= 1")])
def test_bad_reference_input_is_one_line(args, words, tmp_path, svgen_cli):
    (tmp_path / "empty").mkdir()
    args = [str(tmp_path / "empty") if a == "EMPTY" else a for a in args]
    code, out = svgen_cli("reference", *args, tmp_path / "out", "--workers", 0)
    lines = out.strip().splitlines()
    assert code == 2 and len(lines) == 1 and words in lines[0] and "Traceback" not in out, out
    if "EMPTY" in args or str(tmp_path / "empty") in args:
        assert str(tmp_path / "empty") in lines[0]  # the folder is named
