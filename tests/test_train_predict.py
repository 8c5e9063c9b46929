"""``svtrain predict`` at capture size: sizes from one 512² photo, folders (batched, one output folder per photo,
broken photos listed after the valid ones are written) and the input space of PNGs that hold linear values."""
from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from svcore.image_io import read_exr, srgb_decode, srgb_encode, write_exr

SMALL = ["--set", "model.base_width=4", "--set", "model.max_width=8", "--set", "model.levels=3",
         "--set", "data.crop=32", "--set", "data.synthetic_size=40", "--set", "data.synthetic_samples=16",
         "--set", "data.synthetic_materials=4", "--set", "data.holdout=0.5", "--set", "optim.batch_size=2",
         "--workers", "0", "--no-compile"]
from test_train_cli import run  # noqa: E402  (one svtrain-in-process helper)

MAPS = ("normal", "diffuse", "roughness", "specular")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A model trained at 32² crops (stride 8)."""
    d = tmp_path_factory.mktemp("run")
    code, _, err = run("fit", "--out", d, "--iterations", 2, *SMALL)
    assert code == 0, err
    return d


def photo(rng, h, w) -> np.ndarray:
    return rng.uniform(0.05, 0.6, (h, w, 3)).astype(np.float32)


def written_spec_stats(d) -> dict[str, float]:
    """:func:`train.spec_stats.spec_stats` of the diffuse and specular maps predict wrote into ``d`` (linear EXRs)."""
    import torch

    from train.brdf import DIFFUSE, SPECULAR
    from train.spec_stats import spec_stats

    maps = torch.zeros(1, 10, *read_exr(d / "diffuse.exr").shape[:2])
    for name, sl in (("diffuse", DIFFUSE), ("specular", SPECULAR)):
        maps[0, sl] = torch.from_numpy(read_exr(d / f"{name}.exr")).permute(2, 0, 1)
    return {k: float(v[0]) for k, v in spec_stats(maps).items()}


@pytest.mark.parametrize("size", [128, 256, 512])
def test_sizes_from_one_512_photo(run_dir, tmp_path, rng, size, caplog):
    write_exr(tmp_path / "p.exr", photo(rng, 512, 512))
    out = tmp_path / f"maps{size}"
    code, stdout, err = run("predict", tmp_path / "p.exr", "--checkpoint", run_dir, "--out", out, "--size", size)
    assert code == 0, err
    for m in MAPS:
        assert Image.open(out / f"{m}.png").size == (size, size)
        assert read_exr(out / f"{m}.exr").shape == (size, size, 3)
    np.testing.assert_allclose(np.linalg.norm(read_exr(out / "normal.exr"), axis=-1), 1, atol=1e-4)
    meta = json.loads((out / "prediction.json").read_text())
    assert meta["size"] == size and meta["input_space"] == "linear" and meta["photo_size"] == [512, 512]
    assert meta["config"]["data"]["crop"] == 32 and meta["svgen_version"]
    assert ("note" in meta) == (size > 256)  # above the paper's size: allowed, with a note
    assert ("quality falls off" in caplog.text) == (size > 256)


def test_a_photo_smaller_than_the_size_is_upscaled_with_a_warning(run_dir, tmp_path, rng, caplog):
    write_exr(tmp_path / "small.exr", photo(rng, 64, 96))  # centre square 64² -> 256²: 4x
    out = tmp_path / "maps"
    code, _, err = run("predict", tmp_path / "small.exr", "--checkpoint", run_dir, "--out", out)
    assert code == 0, err
    assert json.loads((out / "prediction.json").read_text())["upscale"] == 4.0
    assert "small.exr: its centre square (64²) is upscaled 4.0x to 256²" in caplog.text
    caplog.clear()
    write_exr(tmp_path / "large.exr", photo(rng, 300, 400))  # shrunk: no warning
    code, _, err = run("predict", tmp_path / "large.exr", "--checkpoint", run_dir, "--out", tmp_path / "m2")
    assert code == 0, err
    assert json.loads((tmp_path / "m2" / "prediction.json").read_text())["upscale"] < 1
    assert "upscaled" not in caplog.text


def test_default_size_is_256(run_dir, tmp_path, rng):
    write_exr(tmp_path / "p.exr", photo(rng, 300, 400))
    code, _, err = run("predict", tmp_path / "p.exr", "--checkpoint", run_dir)
    assert code == 0, err
    assert Image.open(tmp_path / "p_maps" / "diffuse.png").size == (256, 256)


def test_folder_batched_with_a_broken_photo(run_dir, tmp_path, rng):
    src = tmp_path / "photos"
    src.mkdir()
    imgs = {"a": photo(rng, 64, 64), "b": photo(rng, 80, 60), "c": photo(rng, 64, 64)}
    Image.fromarray(np.round(imgs["a"] * 255).astype(np.uint8)).save(src / "a.png")
    Image.fromarray(np.round(imgs["b"] * 255).astype(np.uint8)).save(src / "b.jpg", quality=95)
    write_exr(src / "c.exr", imgs["c"])
    (src / "d.png").write_text("not a png")  # broken
    (src / "notes.txt").write_text("ignored: not a photo type")
    out = tmp_path / "out"
    code, stdout, err = run("predict", src, "--checkpoint", run_dir, "--out", out, "--size", 64, "--batch", 2)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "1 of 4 photo(s) could not be read (3 written)" in lines[0] and "d.png" in lines[0], err
    assert sorted(p.name for p in out.iterdir()) == ["a", "b", "c"]
    for name in "abc":
        assert all((out / name / f"{m}.exr").is_file() for m in MAPS)
        # each photo's specular-copy statistics (#39) are those of its own written maps, not of its batch's first
        assert json.loads((out / name / "prediction.json").read_text())["specular_copy"] == pytest.approx(
            written_spec_stats(out / name), abs=2e-6)
    # batching does not change a photo's maps: c alone equals c in the batch of the folder
    code, _, err = run("predict", src / "c.exr", "--checkpoint", run_dir, "--out", tmp_path / "c1", "--size", 64)
    assert code == 0, err
    np.testing.assert_allclose(read_exr(tmp_path / "c1" / "diffuse.exr"), read_exr(out / "c" / "diffuse.exr"),
                               atol=1e-5)


def test_linear_png_input_space(run_dir, tmp_path):
    """A PNG that stores linear values (the 2018 paper's data): --input-space linear feeds them as they are, auto
    decodes them as sRGB (darker); the network's input (input.png, sRGB-encoded) and prediction.json show which."""
    from train.predict import read_photo

    v = 0.2
    Image.fromarray(np.full((64, 64, 3), round(v * 255), np.uint8)).save(tmp_path / "lin.png")
    stored = round(v * 255) / 255
    assert read_photo(tmp_path / "lin.png", "linear")[0, 0, 0] == pytest.approx(stored, abs=1e-6)
    assert read_photo(tmp_path / "lin.png", "auto")[0, 0, 0] == pytest.approx(srgb_decode(np.float32(stored)), abs=1e-5)
    seen = {}
    for space in ("linear", "auto"):
        out = tmp_path / space
        code, _, err = run("predict", tmp_path / "lin.png", "--checkpoint", run_dir, "--out", out, "--size", 64,
                           "--input-space", space)
        assert code == 0, err
        assert json.loads((out / "prediction.json").read_text())["input_space"] == ("linear" if space == "linear"
                                                                                     else "srgb")
        seen[space] = np.asarray(Image.open(out / "input.png"), np.float32)[..., 0].mean() / 255
    # input.png is the network input sRGB-encoded: linear mode saw 0.2 (encoded ~0.48), auto saw decode(0.2) = 0.033
    assert seen["linear"] == pytest.approx(float(srgb_encode(np.float32(stored))), abs=2 / 255)
    assert seen["auto"] == pytest.approx(stored, abs=2 / 255)


def test_predict_refuses_an_existing_maps_folder_unless_forced(run_dir, tmp_path, rng):
    """Issue #25 item 8: one overwrite rule: an existing output is refused (one line naming --force) before any
    work; --force writes over it; an empty folder holds nothing to lose."""
    write_exr(tmp_path / "p.exr", photo(rng, 64, 64))
    out = tmp_path / "maps"
    out.mkdir()  # empty: not an existing output
    code, _, err = run("predict", tmp_path / "p.exr", "--checkpoint", run_dir, "--out", out, "--size", 64)
    assert code == 0, err
    (out / "diffuse.exr").write_bytes(b"kept")
    code, stdout, err = run("predict", tmp_path / "p.exr", "--checkpoint", run_dir, "--out", out, "--size", 64)
    assert code == 2 and err.count("\n") == 1 and f"output {out} already exists" in err and "--force" in err, err
    assert (out / "diffuse.exr").read_bytes() == b"kept"
    code, _, err = run("predict", tmp_path / "p.exr", "--checkpoint", run_dir, "--out", out, "--size", 64, "--force")
    assert code == 0, err
    assert read_exr(out / "diffuse.exr").shape == (64, 64, 3)
