"""Which views `svtrain eval` evaluates: a store that is not the checkpoint's training store in full by default,
its own training store by its held-out split, the choice stated in eval.json/eval.md; and the warning on a
bootstrap interval over fewer than 5 SVBRDFs."""
from __future__ import annotations

import json

import numpy as np
import pytest

from test_train_cli import SMALL, run
from train.evaluate import MIN_CLUSTERS, markdown, paired

#: SMALL without the synthetic source's keys (these runs train on a store)
STORE_SMALL = [x for pair in zip(SMALL[:-3:2], SMALL[1:-3:2]) if "synthetic" not in pair[1] for x in pair] + SMALL[-3:]


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """A tiny training store, a run trained on it, and a second store of different data (another render seed)."""
    import contextlib
    import io

    from pipeline.cli import cli
    from svcore.cli import run_cli

    def svgen(*args):
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = run_cli(cli, "svgen", [str(a) for a in args])
        assert code == 0, err.getvalue()

    d = tmp_path_factory.mktemp("evalviews")
    svgen("sample", d / "v.zarr", "--per-preset", 2, "--class", "paint", "--size", 64, "--workers", 0)
    svgen("blend", d / "v.zarr", d / "b.zarr", "--count", 4, "--workers", 0)
    for name, seed in (("train.zarr", 0), ("other.zarr", 1)):
        svgen("render", d / "v.zarr", d / "b.zarr", d / name, "--views", 2, "--res", 32, "--seed", seed,
              "--workers", 0)
    code, out, err = run("fit", "--store", d / "train.zarr", "--out", d / "run", "--iterations", 2,
                         "--set", "data.holdout=0.3", *STORE_SMALL)
    assert code == 0, err
    return d


def _eval(d, out, *args):
    code, _, err = run("eval", "--checkpoint", d / "run", "--out", out, *args)
    assert code == 0, err
    return json.loads((out / "eval.json").read_text()), (out / "eval.md").read_text()


def _views(store) -> int:
    from storage.renders_store import RendersReader

    return len(RendersReader(store))


def test_a_foreign_store_is_evaluated_in_full(stores, tmp_path):
    res, md = _eval(stores, tmp_path / "other", "--store", stores / "other.zarr")
    n = _views(stores / "other.zarr")
    assert res["suite"] == "all" and res["samples"] == n
    assert res["views"]["evaluated"] == n and res["views"]["store_views"] == n
    assert "not the checkpoint's training store" in res["views"]["why"]
    assert f"Views evaluated: {n} (every view) of the {n} in other.zarr" in md
    # asked for explicitly, the held-out split of a foreign store is still possible, and said so
    res, md = _eval(stores, tmp_path / "other_h", "--store", stores / "other.zarr", "--suite", "heldout")
    assert res["suite"] == "heldout" and res["samples"] < n
    assert "--suite heldout was asked for" in md


def test_the_training_store_is_evaluated_by_its_heldout_split(stores, tmp_path):
    n = _views(stores / "train.zarr")
    for args in ((), ("--store", stores / "train.zarr")):  # named or not, it is the training store
        res, md = _eval(stores, tmp_path / f"own{len(args)}", *args)
        assert res["suite"] == "heldout" and 0 < res["samples"] < n, res["views"]
        assert "the held-out split" in md and "own training store" in res["views"]["why"]


def test_small_sample_intervals_carry_a_warning(stores, tmp_path):
    rng = np.random.default_rng(0)
    for k, warned in ((MIN_CLUSTERS - 1, True), (MIN_CLUSTERS, False)):
        clusters = np.repeat(np.arange(k), 3)
        p = paired(rng.random(3 * k), rng.random(3 * k), clusters, seed=0)
        assert ("warning" in p) == warned, (k, p)
    # in the table: the first 4 views of the foreign store show 2 SVBRDFs (2 views each), the whole store more
    res, md = _eval(stores, tmp_path / "few", "--store", stores / "other.zarr", "--limit", 4)
    assert res["paired"]["dataset_mean"]["rerender"]["clusters"] == 2
    rows = [ln for ln in md.splitlines() if ln.startswith("| rerender |")]
    assert rows and all("⚠ only 2 SVBRDFs (< 5)" in r for r in rows), md
    assert res["paired"]["dataset_mean"]["rerender"]["warning"].startswith("only 2 SVBRDFs")
    res, md = _eval(stores, tmp_path / "other", "--store", stores / "other.zarr")
    assert res["paired"]["dataset_mean"]["rerender"]["clusters"] >= MIN_CLUSTERS
    assert "⚠" not in md and markdown(res) == md
