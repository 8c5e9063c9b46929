"""Imported materials in the pipeline: `svgen sample --from` (perturbation table, seeds, variant 0 = the material),
and the tiny end to end: import -> sample --from with presets -> blend -> render -> svtrain fit -> svtrain eval
--store on an imported `--as renders` store of 2018 strips."""
from __future__ import annotations

import json
import zlib

import numpy as np
import pytest

from import_fixtures import ambientcg, bumpy_normals, png8
from conftest import tree_digest
from pipeline.importer import normals as nm
from pipeline.importer.perturb import TABLE, apply
from storage.svbrdf_store import SVBRDFStore
from svcore.seeds import derive_seed
from materials.maps import SVBRDF


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    from pipeline.config import ImportConfig
    from pipeline.importer.job import run_import
    from svcore.config import build

    d = tmp_path_factory.mktemp("imp")
    rng = np.random.default_rng(3)
    for k in range(2):
        ambientcg(d / "src", f"Rock{k}", 64, np.random.default_rng(k), {"GL": bumpy_normals(64, rng)})
    path, _ = run_import(d / "imp.zarr", build(ImportConfig, sources=(str(d / "src"),), size=64), workers=0)
    return path


def test_sample_from_imported(imported, tmp_path, svgen_cli):
    code, err = svgen_cli("sample", tmp_path / "v.zarr", "--from", imported, "--per-material", 3, "--per-preset", 2,
                          "--preset", "paint/glossy_red", "--size", 64, "--workers", 0)
    assert code == 0, err
    v, imp = SVBRDFStore(tmp_path / "v.zarr"), SVBRDFStore(imported)
    assert len(v) == 2 + 2 * 3
    assert v.presets == ["paint/glossy_red", "imported/Rock0", "imported/Rock1"]
    seeds = v.group["seed"][:]
    params = v.group["params"][:]
    for j, (name, k) in enumerate([(n, k) for n in ("imported/Rock0", "imported/Rock1") for k in range(3)]):
        assert int(seeds[2 + j]) == derive_seed(0, "sample", zlib.crc32(name.encode()), k)  # the presets' rule
    # variant 0 is the imported material itself; the others are perturbed inside the table's ranges
    for a, b in ((2, 0), (5, 1)):
        for k in ("diffuse", "specular", "roughness"):
            assert np.array_equal(v.group[k][a], imp.group[k][b])
        assert np.abs(v.maps(a).normal - imp.maps(b).normal).max() < 2e-4
    for j in (3, 4, 6, 7):
        assert not np.array_equal(v.group["diffuse"][j], v.group["diffuse"][2])
        p = dict(zip(TABLE.names(), params[j][:len(TABLE)]))
        assert all(TABLE[n].low <= x <= TABLE[n].high for n, x in p.items())
    assert v.attrs["param_names"]["imported/Rock0"] == TABLE.names()
    # same bytes again with two worker processes
    code, err = svgen_cli("sample", tmp_path / "v2.zarr", "--from", imported, "--per-material", 3, "--per-preset", 2,
                          "--preset", "paint/glossy_red", "--size", 64, "--workers", 2)
    assert code == 0, err
    assert tree_digest(tmp_path / "v.zarr") == tree_digest(tmp_path / "v2.zarr")


def test_perturbation_rotation_turns_the_surface():
    # a height field rotated a quarter turn has the normals of the rotated field: the table's rotation must agree
    s = 32
    c = (np.arange(s) + 0.5) / s
    u, v = np.meshgrid(c, 1 - c)
    h = 0.5 + 0.2 * np.sin(2 * np.pi * u) + 0.1 * np.cos(4 * np.pi * v) * np.sin(2 * np.pi * u)
    flat = np.full((s, s, 3), 0.5, np.float32)
    m = SVBRDF(normal=nm.from_height(h, 0.2), diffuse=flat, specular=flat, roughness=flat[..., :1])
    p = {**{q.name: q.default for q in TABLE}, "rotation": 1.0}
    got = apply(m, p).normal
    want = nm.from_height(np.rot90(h, 1), 0.2)
    assert np.abs(got - want).max() < 1e-5
    # normal strength scales the slopes
    p = {**{q.name: q.default for q in TABLE}, "normal_strength": 2.0}
    assert np.abs(apply(m, p).normal - nm.from_height(h, 0.4)).max() < 1e-5


def test_end_to_end_tiny(imported, tmp_path, svgen_cli):
    from test_train_cli import SMALL, run

    rng = np.random.default_rng(5)
    assert svgen_cli("sample", tmp_path / "v.zarr", "--from", imported, "--per-material", 2, "--per-preset", 1,
                     "--class", "paint", "--size", 64, "--workers", 0)[0] == 0
    assert svgen_cli("blend", tmp_path / "v.zarr", tmp_path / "b.zarr", "--count", 4, "--workers", 0)[0] == 0
    code, err = svgen_cli("render", tmp_path / "v.zarr", tmp_path / "b.zarr", tmp_path / "r.zarr", "--views", 2,
                          "--res", 32, "--workers", 0)
    assert code == 0, err
    presets = json.loads((tmp_path / "r.zarr" / "zarr.json").read_text())["attributes"]["presets"]
    assert "imported/Rock0" in presets
    small = [x for pair in zip(SMALL[:-3:2], SMALL[1:-3:2]) if "synthetic" not in pair[1] for x in pair] + SMALL[-3:]
    code, out, err = run("fit", "--store", tmp_path / "r.zarr", "--out", tmp_path / "run", "--iterations", 2, *small)
    assert code == 0, err
    # the 2018 strips' own photos as a renders store, evaluated as published
    (tmp_path / "strips").mkdir()
    t = 32
    for k in range(4):
        n = bumpy_normals(t, rng)
        strip = np.concatenate([rng.random((t, t, 3)) * 0.5, (n + 1) / 2, rng.random((t, t, 3)),
                                rng.random((t, t, 3)).mean(-1, keepdims=True).repeat(3, -1),
                                rng.random((t, t, 3)) * 0.3], axis=1)
        png8(tmp_path / "strips" / f"{k:04d};test.png", strip)
    code, err = svgen_cli("import", tmp_path / "strips", tmp_path / "test.zarr", "--as", "renders", "--size", t,
                          "--workers", 0)
    assert code == 0, err
    code, out, err = run("eval", "--checkpoint", tmp_path / "run", "--store", tmp_path / "test.zarr", "--out",
                         tmp_path / "eval")
    assert code == 0, err
    res = json.loads((tmp_path / "eval" / "eval.json").read_text())
    assert all(np.isfinite(v) for v in res["model"].values())
    # every published sample, not only a held-out split of them
    code, out, err = run("eval", "--checkpoint", tmp_path / "run", "--store", tmp_path / "test.zarr", "--suite",
                         "all", "--out", tmp_path / "eval_all")
    assert code == 0, err
    res = json.loads((tmp_path / "eval_all" / "eval.json").read_text())
    assert res["samples"] == 4 and all(np.isfinite(v) for v in res["model"].values())
