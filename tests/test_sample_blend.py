"""`svgen sample` and `svgen blend`: determinism, worker invariance, perturbation law, normal blending, bad input."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st
from scipy import stats

import materials
from conftest import tree_digest
from pipeline.blend import MIN_NZ, blend_normals, mask
from pipeline.config import SampleConfig
from pipeline.sample import VariantSpec, perturb, plan
from storage.svbrdf_store import SVBRDFStore
from svcore.config import build

TWO = ("--preset", "paint/glossy_red", "--preset", "paint/matte_wall")


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    """A tiny variants store written in-process (--workers 0) by the command (whose line the store records: the
    dask run below is compared with it file for file)."""
    from pipeline.cli import cli
    from test_bad_input import call

    out = tmp_path_factory.mktemp("v") / "v.zarr"
    code, err = call(cli, "svgen", ["sample", out, "--config-preset", "tiny", "--per-preset", 3, "--chunk", 2,
                                    "--workers", 0, *TWO])
    assert code == 0, err
    return out


def test_variants_store_holds_valid_maps_and_provenance(variants):
    s = SVBRDFStore(variants, "variants")
    assert len(s) == 6 and s.size == 64
    for i in range(len(s)):
        s.check_maps(i)
    assert s.source(0)["presets"] == ["paint/glossy_red"] and s.source(3)["presets"] == ["paint/matte_wall"]
    params = s.group["params"][:]
    pre = materials.get_preset("paint/glossy_red")
    assert np.allclose(params[0, :len(pre.exposed)], list(pre.defaults().values()))  # variant 0 = defaults
    assert not np.allclose(params[1], params[0], equal_nan=True)


def test_same_bytes_with_dask_workers_as_in_process(variants, tmp_path, svgen_cli):
    out = tmp_path / "v2.zarr"
    code, msg = svgen_cli("sample", out, "--config-preset", "tiny", "--per-preset", 3, "--chunk", 2, "--workers", 2, *TWO)
    assert code == 0, msg
    assert tree_digest(out) == tree_digest(variants)


def test_variant_does_not_depend_on_the_other_presets_selected():
    both = plan(build(SampleConfig, presets=("paint/glossy_red", "paint/matte_wall")))
    one = plan(build(SampleConfig, presets=("paint/matte_wall",)))
    assert [s for s in both if s.preset == "paint/matte_wall"] == list(one)
    assert plan(build(SampleConfig, seed=0))[1].seed != plan(build(SampleConfig, seed=1))[1].seed


def test_perturbation_follows_the_documented_truncated_normal():
    """Chi-square of 1500 draws of every exposed parameter against truncnorm(default, sigma*(hi-lo))."""
    pre = materials.get_preset("paint/glossy_red")
    rng = np.random.default_rng(7)
    draws = [perturb(pre, 1, 0.25, rng) for _ in range(1500)]
    for p in pre.exposed:
        if p.kind == "int" or p.high == p.low:
            continue
        x = np.array([d[p.name] for d in draws])
        scale = 0.25 * (p.high - p.low)
        dist = stats.truncnorm((p.low - p.default) / scale, (p.high - p.default) / scale, loc=p.default, scale=scale)
        edges = dist.ppf(np.linspace(0, 1, 11))
        observed = np.histogram(x, bins=edges)[0]
        assert stats.chisquare(observed).pvalue > 1e-3, p.name
        assert x.min() >= p.low and x.max() <= p.high


def test_blend_store_records_pairs_and_mixes_maps(variants, tmp_path, svgen_cli):
    out = tmp_path / "b.zarr"
    code, msg = svgen_cli("blend", variants, out, "--count", 5, "--workers", 0, "--alpha-low", 0.3, "--alpha-high", 0.7)
    assert code == 0, msg
    b, v = SVBRDFStore(out, "blends"), SVBRDFStore(variants)
    parents, alpha = b.group["parents"][:], b.group["alpha"][:]
    assert ((alpha >= 0.3) & (alpha <= 0.7)).all() and (parents[:, 0] != parents[:, 1]).all()
    ma, mb, m = v.maps(int(parents[0, 0])), v.maps(int(parents[0, 1])), b.maps(0)
    expect = alpha[0] * ma.diffuse + (1 - alpha[0]) * mb.diffuse
    assert np.abs(m.diffuse - expect).max() < 2e-5  # two 16-bit quantisations
    assert set(b.source(0)["presets"]) <= {"paint/glossy_red", "paint/matte_wall"}


def test_mask_blends_are_tileable_and_have_mean_alpha():
    ms = np.stack([mask(128, s, 0.3, 4.0) for s in range(40)])
    assert abs(ms.mean() - 0.3) < 0.05
    assert ms.min() >= 0 and ms.max() <= 1
    m = ms[0, ..., 0]
    interior = np.abs(np.diff(m, axis=1)).mean()
    seam = np.abs(m[:, 0] - m[:, -1]).mean()
    assert seam < 3 * interior + 1e-3


def test_opposite_normals_blend_to_the_flat_normal():
    s = np.sqrt(0.5)
    na = np.array([[[s, 0, s]]], np.float32)
    nb = np.array([[[-s, 0, s]]], np.float32)
    assert np.allclose(blend_normals(na, nb, 0.5), [[[0, 0, 1]]], atol=1e-6)
    grazing_a = np.array([[[1.0, 0, 0]]], np.float32)  # z = 0: clamped, still finite with z > 0
    out = blend_normals(grazing_a, nb, 0.5)
    assert np.isfinite(out).all() and out[..., 2].min() > 0


unit_normal = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(1e-3, 1)).map(
    lambda v: np.array(v, np.float32) / np.linalg.norm(v))


@settings(max_examples=200, deadline=None, derandomize=True)  # CI draws the same examples every run
@given(unit_normal, unit_normal, st.floats(0, 1))
def test_blended_normals_are_unit_with_positive_z_and_keep_endpoints(a, b, w):
    assume(a[2] > 2 * MIN_NZ)  # flatter normals are clamped on purpose (finite slopes)
    out = blend_normals(a[None, None], b[None, None], w)[0, 0]
    assert abs(np.linalg.norm(out) - 1) < 1e-5 and out[2] > 0
    assert np.allclose(blend_normals(a[None, None], b[None, None], 1.0)[0, 0], a, atol=1e-4)


@pytest.mark.parametrize("args, message", [
    (("sample", "{tmp}/o.zarr", "--preset", "paint/nope"), "unknown preset"),
    (("sample", "{tmp}/o.zarr", "--class", "cheese"), "unknown material class"),
    (("sample", "{tmp}/o.zarr", "--size", "63"), "size must be"),
    (("sample", "{tmp}/o.zarr", "--sigma", "-1"), "sigma"),
    (("sample", "{tmp}/o.zarr", "--config-preset", "huge"), "'huge' is not one of"),
    (("sample", "{tmp}/o.zarr", "--params", "{tmp}/missing.yaml"), "does not exist"),
    (("sample", "{tmp}/exists.zarr", "--config-preset", "tiny", *TWO), "already exists"),
    (("blend", "{tmp}/exists.zarr", "{tmp}/b.zarr"), "not a zarr v3 store"),
    (("blend", "{tmp}/nothing.zarr", "{tmp}/b.zarr"), "no store"),
    (("blend", "{variants}", "{tmp}/b.zarr", "--alpha-low", "0.9", "--alpha-high", "0.1"), "alpha_low"),
])
def test_bad_input_gives_one_line_and_nonzero_exit(args, message, tmp_path, variants, svgen_cli):
    (tmp_path / "exists.zarr").mkdir()
    code, msg = svgen_cli(*[a.format(tmp=tmp_path, variants=variants) for a in args])
    assert code != 0
    assert message in msg and msg.count("\n") == 1 and "Traceback" not in msg, msg
    assert not (tmp_path / "o.zarr").exists() and not (tmp_path / "b.zarr").exists()
    assert list((tmp_path / "exists.zarr").iterdir()) == []


def test_blend_refuses_a_blends_store_as_input(variants, tmp_path, svgen_cli):
    assert svgen_cli("blend", variants, tmp_path / "b.zarr", "--count", 2, "--workers", 0)[0] == 0
    code, msg = svgen_cli("blend", tmp_path / "b.zarr", tmp_path / "bb.zarr")
    assert code != 0 and "is a blends store, expected a variants store" in msg


def test_the_lazy_plan_is_the_list_of_every_variant():
    """``plan`` makes variant i on demand (a million-variant stage lists nothing up front): it must be exactly the
    preset-by-preset list of (preset, k, derive_seed(seed, "sample", crc32(preset), k)), slices included."""
    import zlib

    from svcore.seeds import derive_seed

    cfg = build(SampleConfig, presets=("paint/glossy_red", "paint/matte_wall"), per_preset=3, seed=7)
    lazy = plan(cfg)
    eager = [VariantSpec(n, k, derive_seed(7, "sample", zlib.crc32(n.encode()), k))
             for n in ("paint/glossy_red", "paint/matte_wall") for k in range(3)]
    assert len(lazy) == 6 and list(lazy) == eager and lazy[2:5] == eager[2:5] and lazy[-1] == eager[-1]
    with pytest.raises(IndexError):
        lazy[6]
