"""`svgen stats`: summary numbers equal direct computations on known maps; two stores side by side."""
from __future__ import annotations

import json

import numpy as np
import pytest

from import_fixtures import exr
from pipeline.config import ImportConfig
from pipeline.importer.job import run_import
from pipeline.stats import LUMA, store_stats
from svcore.config import build


@pytest.fixture(scope="module")
def known(tmp_path_factory):
    """Three EXR materials (linear, so stored values are known to 16-bit precision)."""
    d = tmp_path_factory.mktemp("stats")
    rng = np.random.default_rng(0)
    maps = []
    for k in range(3):
        m = d / "src" / f"m{k}"
        m.mkdir(parents=True)
        diff = rng.random((16, 16, 3)).astype(np.float32) * (k + 1) / 3
        spec = np.full((16, 16, 3), 0.02 + 0.1 * k, np.float32)
        spec[:8, :, 0] += 0.3  # half the material reddish: spatial variation and saturation
        exr(m / "diffuse.exr", diff)
        exr(m / "specular.exr", spec)
        exr(m / "roughness.exr", np.full((16, 16), 0.25 * (k + 1), np.float32), "Y")
        maps.append((diff, spec))
    path, _ = run_import(d / "s.zarr", build(ImportConfig, sources=(str(d / "src"),), size=16), workers=0)
    return path, maps


def test_summary_matches_direct_computation(known):
    path, maps = known
    s = store_stats(path, stride=1)
    spec_y = [sp.reshape(-1, 3) @ LUMA for _, sp in maps]
    diff_y = [df.reshape(-1, 3) @ LUMA for df, _ in maps]
    tol = 3e-5  # 16-bit storage
    assert s["summary"]["specular Y median"] == pytest.approx(np.median(np.concatenate(spec_y)), abs=tol)
    assert s["summary"]["specular Y spatial std"] == pytest.approx(np.mean([y.std() for y in spec_y]), abs=tol)
    f0 = [sp.reshape(-1, 3).mean(0) for _, sp in maps]
    assert s["summary"]["specular saturation"] == pytest.approx(np.mean([(f.max() - f.min()) / f.max() for f in f0]),
                                                                abs=1e-3)
    r = np.corrcoef([y.mean() for y in diff_y], [y.mean() for y in spec_y])[0, 1]
    assert s["summary"]["diffuse-specular r"] == pytest.approx(r, abs=1e-3)
    assert s["summary"]["roughness median"] == pytest.approx(0.5, abs=tol)
    assert s["summary"]["slope spread (deg)"] == pytest.approx(0.0, abs=1e-3)  # flat normals
    assert sum(s["maps"]["roughness"]["hist"][0]) == 3 * 16 * 16


def test_cli_side_by_side(known, tmp_path, svgen_cli):
    path, _ = known
    from pipeline.config import SampleConfig
    from pipeline.sample import run_sample

    run_sample(tmp_path / "v.zarr", build(SampleConfig, "tiny", presets=("metal/brushed_steel",), per_preset=1),
               workers=0)
    code, out = svgen_cli("stats", path, tmp_path / "v.zarr", "--out", tmp_path / "st")
    assert code == 0, out
    res = json.loads((tmp_path / "st" / "stats.json").read_text())
    assert [r["kind"] for r in res] == ["variants", "variants"]
    assert "| s.zarr (variants, 3) | v.zarr (variants, 1) |" in out
    assert (tmp_path / "st" / "stats.png").read_bytes()[:4] == b"\x89PNG"
    code, out = svgen_cli("stats", tmp_path / "nothing.zarr")
    assert code == 2 and out.strip().startswith("svgen: error: no store at")
