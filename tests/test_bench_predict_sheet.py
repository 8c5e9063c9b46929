"""benchmarks/bench_predict_sheet.py on a tiny renders store (2 materials and 2 stress categories, 64² views) and a
tiny model (32² crops): the sheet holds rows x columns of tiles where its layout says, the input column is the
stored photo, the ground-truth re-render column equals an independent numpy render of the stored maps
(materials.brdf_reference) under the moved light, the rows' RMSEs are those of `svtrain eval`'s per_view.csv, and a
missing store is refused in one line."""
from __future__ import annotations

import csv
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from materials.brdf_reference import render_point_flash
from materials.maps import SVBRDF
from svcore.image_io import srgb_encode
from test_bad_input import call
from test_train_cli import run as svtrain

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "bench_predict_sheet.py"
CROP = 32
SMALL = ["--set", "model.base_width=4", "--set", "model.max_width=8", "--set", "model.levels=3",
         "--set", f"data.crop={CROP}", "--set", "data.synthetic_size=40", "--set", "data.synthetic_samples=16",
         "--set", "data.synthetic_materials=4", "--set", "data.holdout=0.5", "--set", "optim.batch_size=2",
         "--workers", "0", "--no-compile"]


def sheet_module():
    """The script as a module (its layout constants), with benchmarks/ importable as when it runs."""
    sys.path.insert(0, str(SCRIPT.parent))
    try:
        spec = importlib.util.spec_from_file_location("bench_predict_sheet", SCRIPT)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
    finally:
        sys.path.remove(str(SCRIPT.parent))
    return mod


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """One renders store of 2 variants and 2 stress SVBRDFs (2 views of 64² each), and a model trained 2 steps at
    32² crops (stride 8)."""
    from pipeline.cli import cli

    d = tmp_path_factory.mktemp("sheet")
    for args in (["sample", d / "v.zarr", "--config-preset", "tiny", "--per-preset", "1", "--preset",
                  "paint/glossy_red", "--preset", "wood/oak_planks", "--workers", "0"],
                 ["stress", d / "s.zarr", "--config-preset", "tiny", "--per-category", "1", "--category",
                  "highlight_edge", "--category", "print_pattern", "--size", "64", "--workers", "0"],
                 ["render", d / "v.zarr", d / "s.zarr", d / "r.zarr", "--config-preset", "tiny", "--views", "2",
                  "--res", "64", "--chunk", "2", "--workers", "0"]):
        code, err = call(cli, "svgen", [str(a) for a in args])
        assert code == 0, (args[0], err)
    code, _, err = svtrain("fit", "--out", d / "run", "--iterations", 2, *SMALL)
    assert code == 0, err
    return d


def bench(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True,
                          timeout=600)


@pytest.fixture(scope="module")
def sheet(inputs):
    """The sheet of 2 reference rows and 2 stress rows (one store serves as both)."""
    r = bench("--checkpoint", inputs / "run", "--reference", inputs / "r.zarr", "--stress", inputs / "r.zarr",
              "--n-reference", 2, "--n-stress", 2, "--image", inputs / "sheet.png", "--out", inputs / "sheet.json")
    assert r.returncode == 0, r.stderr[-3000:]
    return np.asarray(Image.open(inputs / "sheet.png").convert("RGB")), json.loads((inputs / "sheet.json").read_text())


def tile(img: np.ndarray, res: dict, row: int, col: int) -> np.ndarray:
    y = res["layout"]["row_y"][row]
    return img[y:y + CROP, col * CROP:(col + 1) * CROP].astype(np.int64)


def test_sheet_is_rows_by_columns_of_tiles(sheet):
    img, res = sheet
    m = sheet_module()
    rows = 4
    assert img.shape == (m.TITLE_PX + m.HEADER_PX + rows * (m.LABEL_PX + CROP), len(m.COLUMNS) * CROP, 3)
    assert [r["store"] for r in res["rows"]] == ["reference"] * 2 + ["stress"] * 2
    assert len({r["svbrdf"] for r in res["rows"][:2]}) == 2  # reference rows: two materials
    assert sorted(r["label"] for r in res["rows"][2:]) == ["highlight_edge", "print_pattern"]
    assert res["checkpoint"]["step"] == 2 and not Path(res["checkpoint"]["path"]).is_absolute()


def test_input_and_truth_rerender_columns(inputs, sheet):
    """Input: the stored view's centre crop, sRGB-encoded; truth re-render: a numpy render of the stored maps under
    the moved light (independent of train/render.py), each to 8-bit rounding."""
    from storage.renders_store import RendersReader

    img, res = sheet
    src = RendersReader(inputs / "r.zarr")
    lo = (src.res - CROP) // 2
    for k, row in enumerate(res["rows"]):
        i = row["view"]
        photo = src.image(i)[lo:lo + CROP, lo:lo + CROP]
        assert np.abs(tile(img, res, k, 0) - np.round(srgb_encode(photo) * 255)).max() <= 1
        m = src.maps(i)
        crop = SVBRDF(*(getattr(m, f)[lo:lo + CROP, lo:lo + CROP] for f in ("normal", "diffuse", "specular",
                                                                             "roughness")))
        want = np.round(srgb_encode(np.clip(render_point_flash(crop, tuple(res["moved_light"])), 0, 1)) * 255)
        got = tile(img, res, k, len(res["layout"]["columns"]) - 1)
        assert np.abs(got - want).mean() < 0.5 and np.abs(got - want).max() <= 3, (k, np.abs(got - want).max())


def test_rows_rmse_are_svtrain_evals(inputs, sheet):
    """The same views through `svtrain eval` (same input pipeline): the same per-view normal and re-render RMSEs."""
    _, res = sheet
    code, _, err = svtrain("eval", "--checkpoint", inputs / "run", "--store", inputs / "r.zarr", "--suite", "all",
                           "--out", inputs / "eval", "--train-store", inputs / "r.zarr")
    assert code == 0, err
    with open(inputs / "eval" / "per_view.csv") as f:
        per_view = {int(r["view"]): r for r in csv.DictReader(f)}
    for row in res["rows"]:
        for c in ("normal", "rerender"):
            assert row[c] == pytest.approx(float(per_view[row["view"]][c]), rel=1e-4, abs=1e-6)


def test_missing_store_is_one_line(inputs, tmp_path):
    r = bench("--checkpoint", inputs / "run", "--reference", tmp_path / "absent.zarr", "--image",
              tmp_path / "s.png", "--out", tmp_path / "s.json")
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.count("\n") == 1 and "no reference renders store at" in r.stderr
    assert not (tmp_path / "s.png").exists() and not (tmp_path / "s.json").exists()
