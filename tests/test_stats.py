"""`svgen stats`: summary numbers equal direct computations on known maps; two stores side by side."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from import_fixtures import exr
from pipeline.config import ImportConfig
from pipeline.importer.job import run_import
from pipeline.stats import LUMA, store_stats
from svcore.config import build


#: material k's right three quarters are tilted by TILTS[k] degrees about the y axis, its left quarter flat.
TILTS = (10.0, 20.0, 30.0)


def tilted_normals(deg: float, s: int = 16) -> np.ndarray:
    """(s, s, 3): left quarter (0, 0, 1), the rest (sin t, 0, cos t)."""
    n = np.zeros((s, s, 3), np.float32)
    n[..., 2] = 1
    t = np.radians(deg)
    n[:, s // 4:] = (np.sin(t), 0, np.cos(t))
    return n


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
        spec_y = spec @ LUMA
        exr(m / "diffuse.exr", diff)
        exr(m / "specular.exr", spec)
        # roughness = specular Y + a constant: r(roughness, specular) = +1 within the material
        exr(m / "roughness.exr", (0.25 * (k + 1) + spec_y - spec_y.mean()).astype(np.float32), "Y")
        exr(m / "normal.exr", (tilted_normals(TILTS[k]) + 1) / 2)  # encoded like a PNG normal map
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
    # per material the slope angle is 0 on a quarter and TILTS[k] on the rest: mean 3/4 t, std t sqrt(3/16)
    assert s["summary"]["slope spread (deg)"] == pytest.approx(np.mean(TILTS) * np.sqrt(3) / 4, abs=0.02)
    assert s["per_material"]["slope_std_deg"] == pytest.approx([t * np.sqrt(3) / 4 for t in TILTS], abs=0.02)
    assert s["per_material"]["slope_mean_deg"] == pytest.approx([t * 3 / 4 for t in TILTS], abs=0.02)
    # 192 pixels at each of 0, 10, 20, 30 degrees: the median lies halfway between 10 and 20
    assert s["summary"]["slope median (deg)"] == pytest.approx(15.0, abs=0.02)
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


def test_stats_out_follows_the_one_overwrite_rule(known, tmp_path, svgen_cli):
    """An --out folder that holds files is refused before any work (one line, exit 2), kept as it was; --force
    writes; an empty folder is no existing output (svcore.outputs)."""
    path, _ = known
    (tmp_path / "st").mkdir()
    (tmp_path / "st" / "stats.json").write_text("keep")
    code, out = svgen_cli("stats", path, "--out", tmp_path / "st")
    assert code == 2 and out.count("\n") == 1 and "already exists" in out and "--force" in out, out
    assert (tmp_path / "st" / "stats.json").read_text() == "keep" and len(list((tmp_path / "st").iterdir())) == 1
    code, out = svgen_cli("stats", path, "--out", tmp_path / "st", "--force")
    assert code == 0, out
    assert json.loads((tmp_path / "st" / "stats.json").read_text())[0]["kind"] == "variants"
    (tmp_path / "empty").mkdir()
    code, out = svgen_cli("stats", path, "--out", tmp_path / "empty")
    assert code == 0 and (tmp_path / "empty" / "stats.md").exists(), out


def test_realism_profile_of_known_store(known):
    """Stored maps through the store reader: each realism statistic equals its closed-form value."""
    from pipeline.stats.profile import profile

    path, maps = known
    p = profile(path)
    assert len(p) == 3 and p.size == 16
    # the slope magnitude is 0 on a quarter and tan(t) on the rest: std / mean = (sqrt(3) / 4) / (3 / 4)
    assert p.per_material["cv_relief"] == pytest.approx([1 / np.sqrt(3)] * 3, abs=1e-3)
    assert p.per_material["r_roughness_specular"] == pytest.approx([1.0] * 3, abs=1e-3)
    spec_y = [sp @ LUMA for _, sp in maps]
    assert p.per_material["cv_specular"] == pytest.approx([y.std() / y.mean() for y in spec_y], abs=1e-3)
    tilt = np.sort(p.pixels["normal_tilt_deg"], axis=1)
    assert tilt[:, :64] == pytest.approx(0.0, abs=0.02)  # 16² pixels: a quarter flat, the rest at TILTS[k]
    assert tilt[:, 64:] == pytest.approx(np.repeat(np.array(TILTS)[:, None], 192, 1), abs=0.02)


def test_cli_reference_distances(known, tmp_path, svgen_cli):
    """`svgen stats STORE --reference REF` end to end: a store against itself is at distance 0; the report's
    floor is the halves' distance; the table, JSON and chart are written."""
    from pipeline.stats.compare import STATS, noise_floor
    from pipeline.stats.profile import profile

    path, _ = known
    code, out = svgen_cli("stats", path, "--reference", path, "--out", tmp_path / "st", "--splits", "3")
    assert code == 0, out
    rep = json.loads((tmp_path / "st" / "realism.json").read_text())
    assert set(rep["distances"]) == set(STATS)
    assert rep["stores"][0]["name"] == "s.zarr#2" and rep["reference"]["name"] == "s.zarr"
    floor = noise_floor(profile(path), 3, 0)
    for k, d in rep["distances"].items():
        assert d["to_reference"]["s.zarr#2"] == pytest.approx(0.0, abs=1e-9), k
        assert d["noise_floor"] == pytest.approx(floor[k]["mean"]), k
    assert rep["distances"]["normal_tilt_deg"]["noise_floor"] > 1.0  # halves of 10/20/30-degree tilts differ
    assert "| normal tilt (deg) | Wasserstein-1 | 0 (0.0×) |" in out
    assert (tmp_path / "st" / "realism.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "st" / "stats.json").exists()  # the plain statistics are still written beside it


def test_cli_reference_bad_input(known, tmp_path, svgen_cli):
    """A reference that is not a store, missing, empty or too small: one line, exit 2."""
    from pipeline.config import SampleConfig
    from pipeline.sample import run_sample

    path, _ = known
    one = run_sample(tmp_path / "one.zarr", build(SampleConfig, "tiny", presets=("metal/brushed_steel",),
                                                  per_preset=1), workers=0)
    (tmp_path / "empty").mkdir()
    for ref, says in ((Path(path).parent / "src", "is not a store: import the folder first"),
                      (tmp_path / "nothing.zarr", "no store at"),
                      (tmp_path / "empty", "is not a store"),
                      (one, "holds 1 materials: at least 2 are needed")):
        code, out = svgen_cli("stats", path, "--reference", ref)
        assert code == 2, out
        assert out.startswith("svgen: error: ") and says in out and out.count("\n") == 1, out


def test_realism_of_blends_and_their_renders_store(tmp_path, svgen_cli):
    """A renders store is profiled on its base maps: the same statistics as the blends store it rendered."""
    from pipeline.stats.compare import distances
    from pipeline.stats.profile import profile

    for args in (("sample", tmp_path / "v.zarr", "--config-preset", "tiny", "--preset", "metal/brushed_steel",
                  "--preset", "wood/oak_planks", "--per-preset", 2, "--size", 64),
                 ("blend", tmp_path / "v.zarr", tmp_path / "b.zarr", "--count", 3),
                 ("render", tmp_path / "b.zarr", tmp_path / "r.zarr", "--config-preset", "tiny", "--views", 1)):
        code, out = svgen_cli(*args, "--workers", 0)
        assert code == 0, out
    b, r = profile(tmp_path / "b.zarr"), profile(tmp_path / "r.zarr")
    assert (b.kind, r.kind, len(b), len(r)) == ("blends", "renders", 3, 3)
    assert all(v == pytest.approx(0.0, abs=1e-9) for v in distances(b, r).values())
    assert distances(b, profile(tmp_path / "v.zarr"))["roughness"] > 0  # blends are not their variants
