"""`svgen import` bad input, table-driven: one clear line on stderr, exit 2, no traceback, nothing at OUT."""
from __future__ import annotations

import os

import numpy as np
import pytest

from import_fixtures import exr, png8
from test_bad_input import call
from pipeline.cli import cli


def material(d, s=32, **extra):
    d.mkdir(parents=True, exist_ok=True)
    png8(d / "basecolor.png", np.full((s, s, 3), 0.5))
    png8(d / "roughness.png", np.full((s, s), 0.5))
    for name, a in extra.items():
        png8(d / name, a)
    return d


def empty(d):
    (d / "src").mkdir()


def unrecognised(d):
    (d / "src").mkdir()
    (d / "src" / "notes.txt").write_text("hello")
    png8(d / "src" / "holiday.png", np.zeros((8, 8, 3)))


def not_an_image(d):
    material(d / "src" / "m")
    (d / "src" / "m" / "normal.png").write_text("not a png")


def truncated(d):
    m = material(d / "src" / "m", s=64)
    png8(m / "normal.png", np.random.default_rng(0).random((64, 64, 3)))
    b = (m / "normal.png").read_bytes()
    (m / "normal.png").write_bytes(b[: len(b) // 2])


def aspect(d):
    m = material(d / "src" / "m")
    png8(m / "normal.png", np.full((32, 64, 3), 0.5))


def one_channel_normal(d):
    material(d / "src" / "m", **{"normal.png": np.full((32, 32), 0.5)})


def nan_exr(d):
    m = material(d / "src" / "m")
    a = np.full((32, 32, 3), 0.5, np.float32)
    a[3, 4] = np.nan
    exr(m / "specular.exr", a)


def duplicates(d):
    material(d / "src" / "a" / "brick")
    material(d / "src" / "b" / "brick")


def symlink_loop(d):
    material(d / "src" / "m")
    os.symlink(d / "src", d / "src" / "m" / "loop")


def too_small(d):
    material(d / "src" / "m", s=16)


def no_colour(d):
    (d / "src" / "m").mkdir(parents=True)
    png8(d / "src" / "m" / "roughness.png", np.full((32, 32), 0.5))


def strip_not_five(d):
    (d / "src").mkdir()
    png8(d / "src" / "s.png", np.zeros((32, 32 * 4, 3)))


def strip_not_square(d):
    (d / "src").mkdir()
    png8(d / "src" / "s.png", np.zeros((30, 32 * 5, 3)))


def renders_from_folders(d):
    material(d / "src" / "m")


CASES = [  # (id, builder, extra args, words expected in the message)
    ("missing source", None, [], "does not exist"),
    ("empty folder", empty, [], "is empty"),
    ("no recognisable maps", unrecognised, [], "no recognisable maps"),
    ("unreadable image", not_an_image, [], "cannot read image"),
    ("truncated image", truncated, [], "cannot read image"),
    ("different aspect ratios", aspect, [], "different aspect ratios"),
    ("1-channel normal", one_channel_normal, [], "needs 2 or 3 channels"),
    ("NaN in EXR", nan_exr, [], "NaN or infinite"),
    ("duplicate names", duplicates, [], "duplicate material name"),
    ("symlink loop", symlink_loop, [], "symlink loop"),
    ("smaller than --size", too_small, [], "smaller than --size"),
    ("no colour map", no_colour, [], "has no basecolor"),
    ("strip not 5 tiles", strip_not_five, ["--layout", "deschaintre"], "is not 5 tiles"),
    ("strip tiles not square", strip_not_square, ["--layout", "deschaintre"], "not square"),
    ("--as renders on folders", renders_from_folders, ["--as", "renders", "--layout", "folders"], "deschaintre"),
    ("bad size", renders_from_folders, ["--size", "3"], "size must be"),
    ("crop above 1", renders_from_folders, ["--crop", "1.5"], "crop must be <= 1"),
    ("crop of 0", renders_from_folders, ["--crop", "0"], "crop must be > 0"),
    ("crop centre outside", renders_from_folders, ["--set", "crop_centre=[1.5,0.5]"], "crop_centre must be two"),
    ("crop window below --size", renders_from_folders, ["--crop", "0.5"], "the crop window (0.5 of a 32-pixel map)"),
    ("crop on 2018 strips", strip_not_five, ["--layout", "deschaintre", "--crop", "0.5"], "apply to material folders"),
    ("capture_cm of 0", renders_from_folders, ["--capture-cm", "0"], "capture_cm must be > 0"),
]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_import_bad_input(case, tmp_path):
    _, build, extra, words = case
    if build is not None:
        build(tmp_path)
    out = tmp_path / "out.zarr"
    code, err = call(cli, "svgen", ["import", tmp_path / "src", out, "--size", 32, "--workers", 0, *extra])
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("svgen: error:"), err
    assert words in lines[0], err
    assert "Traceback" not in err
    assert not out.exists() and not (tmp_path / "out.zarr.partial").exists()


def test_output_inside_a_source_is_refused(tmp_path):
    """#15's rule for every stage: no command writes into its input (a source folder, or an imported store)."""
    material(tmp_path / "src" / "m", s=64)
    out = tmp_path / "src" / "out.zarr"
    code, err = call(cli, "svgen", ["import", tmp_path / "src", out, "--size", 64, "--workers", 0])
    assert code == 2 and "lies inside input" in err, err
    assert not out.exists() and not (tmp_path / "src" / "out.zarr.partial").exists()
    code, err = call(cli, "svgen", ["import", tmp_path / "src", tmp_path / "imp.zarr", "--size", 64, "--workers", 0])
    assert code == 0, err
    inner = tmp_path / "imp.zarr" / "v.zarr"
    code, err = call(cli, "svgen", ["sample", inner, "--from", tmp_path / "imp.zarr", "--size", 64, "--only-from",
                                    "--workers", 0])
    assert code == 2 and "lies inside input" in err, err
    assert not inner.exists()
