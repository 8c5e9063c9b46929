"""Cross-validation folds over a reference library (svcore.split.material_folds) and the leak check that keeps
every evaluated material out of the training data (check_unseen), on a store written by the real stages."""
from __future__ import annotations

import numpy as np
import pytest

from svcore.errors import StoreError
from svcore.split import check_unseen, material_folds

NAMES = [f"imported/M{i:02d}" for i in range(11)]


def test_folds_partition_the_names_evenly_whatever_their_order():
    folds = material_folds(NAMES, 3, seed=0)
    flat = [n for f in folds for n in f]
    assert sorted(flat) == sorted(NAMES) and len(flat) == len(set(flat))  # disjoint, complete
    assert max(map(len, folds)) - min(map(len, folds)) <= 1
    assert material_folds(list(reversed(NAMES)) + NAMES[:2], 3, seed=0) == folds  # order, duplicates: same folds
    assert material_folds(NAMES, 3, seed=1) != folds  # the seed picks the deal


def test_folds_refuse_impossible_counts():
    with pytest.raises(StoreError, match="folds"):
        material_folds(NAMES[:2], 3)
    with pytest.raises(StoreError, match="folds"):
        material_folds(NAMES, 1)


def test_leak_check_on_a_rendered_fold_store(tmp_path, svgen_cli):
    """Import real-format materials, render one fold's training store from the others: the check passes for the
    fold it was built for and fails when one evaluated material is leaked into training on purpose."""
    from storage.renders_store import RendersReader
    from tests.import_fixtures import ambientcg, bumpy_normals

    rng = np.random.default_rng(0)
    src = [ambientcg(tmp_path / "src", n, 32, rng, {"GL": bumpy_normals(32, rng)}) for n in ("Aa", "Bb", "Cc")]
    held = material_folds([f"imported/{p.name}" for p in src], 3, seed=0)[0]
    train_dirs = [p for p in src if f"imported/{p.name}" not in held]
    leaked = [p for p in src if f"imported/{p.name}" in held][0]

    def fold_store(tag: str, dirs) -> list:
        for args in (("import", *dirs, tmp_path / f"{tag}_imp.zarr", "--size", 32),
                     ("render", tmp_path / f"{tag}_imp.zarr", tmp_path / f"{tag}_r.zarr", "--config-preset", "tiny",
                      "--views", 1, "--res", 32)):
            code, out = svgen_cli(*args, "--workers", 0)
            assert code == 0, out
        return RendersReader(str(tmp_path / f"{tag}_r.zarr")).source_presets()

    trained = fold_store("ok", train_dirs)
    assert {n for t in trained for n in t if n} == {f"imported/{p.name}" for p in train_dirs}
    check_unseen(trained, held)  # the fold's own materials were never trained on
    with pytest.raises(StoreError, match=f"imported/{leaked.name}"):
        check_unseen(fold_store("leak", train_dirs + [leaked]), held)


def test_leak_check_ignores_empty_parent_slots():
    # a variant has one material and an empty second parent slot ("" in the store): never a match
    check_unseen([("imported/A", ""), ("imported/B", "")], ["imported/C", ""])
    with pytest.raises(StoreError):
        check_unseen([("imported/A", "imported/C")], ["imported/C"])
