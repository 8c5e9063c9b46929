"""Realism statistics (pipeline/stats/) on synthetic maps whose answers are known in closed form."""
from __future__ import annotations

import numpy as np
import pytest

from pipeline.stats import realism
from pipeline.stats.compare import OCTAVE_STAT, distances, noise_floor, split_halves
from pipeline.stats.profile import Profile


def normals_of_height(dhdx: np.ndarray, dhdy: np.ndarray) -> np.ndarray:
    """Unit normals normalize(-dh/dx, -dh/dy, 1) of a height field's slopes: (N, N, 3) float32."""
    v = np.stack([-dhdx, -dhdy, np.ones_like(dhdx)], -1)
    return (v / np.linalg.norm(v, axis=-1, keepdims=True)).astype(np.float32)


def sine_normals(n: int, kx: int, ky: int, amp: float = 0.02) -> np.ndarray:
    """Normals of h = amp sin(2 pi (kx x + ky y) / n): one spatial frequency of sqrt(kx² + ky²) cycles per map."""
    y, x = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    c = amp * 2 * np.pi / n * np.cos(2 * np.pi * (kx * x + ky * y) / n)
    return normals_of_height(kx * c, ky * c)


@pytest.mark.parametrize("kx,ky,octave", [(1, 0, 0), (0, 3, 1), (5, 0, 2), (3, 4, 2), (12, 0, 3), (0, 40, 5),
                                          (100, 0, 6), (128, 0, 6)])
def test_sinusoid_puts_its_slope_power_in_its_octave(kx, ky, octave):
    shares = realism.octave_shares(sine_normals(256, kx, ky))
    assert shares.sum() == pytest.approx(1.0)
    assert shares[octave] > 0.999, shares  # (3, 4) has radial frequency 5: octave [4, 8)


def test_octave_shares_count_cycles_per_map_at_the_maps_own_size():
    assert realism.octave_shares(sine_normals(64, 5, 0))[2] > 0.999  # 5 cycles per 64² map: [4, 8) as at 256²


def test_two_sinusoids_split_their_power_by_amplitude():
    """Slope power is amplitude² x frequency²: two slope components of equal amplitude share it equally."""
    n = 256
    x = np.arange(n)[None, :].repeat(n, 0)
    dhdx = 0.05 * np.cos(2 * np.pi * 2 * x / n) + 0.05 * np.cos(2 * np.pi * 20 * x / n)
    shares = realism.octave_shares(normals_of_height(dhdx, np.zeros_like(dhdx)))
    assert shares[1] == pytest.approx(0.5, abs=0.01) and shares[4] == pytest.approx(0.5, abs=0.01)


def test_flat_normals_have_no_slope_power():
    flat = np.zeros((64, 64, 3), np.float32)
    flat[..., 2] = 1
    assert realism.octave_shares(flat).tolist() == [0.0] * 7


def test_slopes_invert_the_height_normal():
    rng = np.random.default_rng(0)
    gx, gy = rng.normal(0, 0.3, (2, 8, 8))
    dx, dy = realism.slopes(normals_of_height(gx, gy))
    np.testing.assert_allclose(dx, gx, atol=1e-5)
    np.testing.assert_allclose(dy, gy, atol=1e-5)


def test_cv_constant_is_zero_and_two_levels_known():
    assert realism.cv(np.full((16, 16), 0.37)) == 0.0
    two = np.concatenate([np.full(128, 0.2), np.full(128, 0.6)])  # mean 0.4, std 0.2
    assert realism.cv(two) == pytest.approx(0.5)


def test_variation_of_constant_material_is_zero():
    s = 16
    flat = np.zeros((s, s, 3), np.float32)
    flat[..., 2] = 1
    v = realism.variation(np.full((s, s, 3), 0.3), np.full((s, s, 3), 0.04), np.full((s, s, 1), 0.5), flat)
    assert v == {"cv_diffuse": 0.0, "cv_specular": 0.0, "cv_roughness": 0.0, "cv_relief": 0.0}


def test_correlations_of_linearly_related_maps():
    rng = np.random.default_rng(1)
    s = 16
    spec = rng.uniform(0.02, 0.9, (s, s, 3))
    spec_y = spec @ realism.LUMA
    diff = rng.random((s, s, 3))
    flat = np.zeros((s, s, 3))
    flat[..., 2] = 1
    r = realism.correlations(diff, spec, (0.3 * spec_y + 0.1)[..., None], flat)
    assert r["r_roughness_specular"] == pytest.approx(1.0)
    r = realism.correlations(diff, spec, (0.9 - 0.5 * spec_y)[..., None], flat)
    assert r["r_roughness_specular"] == pytest.approx(-1.0)
    assert r["r_relief_diffuse"] == 0.0  # flat normals: no relief to correlate
    # relief = 2 x diffuse Y (slopes along x of that size): r = +1
    dy = diff @ realism.LUMA
    r = realism.correlations(diff, spec, np.full((s, s, 1), 0.5), normals_of_height(2 * dy, np.zeros_like(dy)))
    assert r["r_relief_diffuse"] == pytest.approx(1.0, abs=1e-6)
    assert r["r_diffuse_roughness"] == 0.0  # constant roughness


def test_diffuse_roughness_correlation_sign():
    """Roughness a linear function of diffuse Y: r = +1 rising with it, -1 falling (closed form, like the
    roughness-specular case above)."""
    rng = np.random.default_rng(2)
    s = 16
    diff = rng.random((s, s, 3))
    dy = diff @ realism.LUMA
    spec = np.full((s, s, 3), 0.04)
    flat = np.zeros((s, s, 3))
    flat[..., 2] = 1
    rising = realism.correlations(diff, spec, (0.2 + 0.5 * dy)[..., None], flat)
    assert rising["r_diffuse_roughness"] == pytest.approx(1.0)
    falling = realism.correlations(diff, spec, (0.9 - 0.6 * dy)[..., None], flat)
    assert falling["r_diffuse_roughness"] == pytest.approx(-1.0)
    assert falling["r_roughness_specular"] == 0.0  # constant specular


def test_pixel_samples_known_values():
    s = 128
    tilt = np.radians(30.0)
    n = np.zeros((s, s, 3), np.float32)
    n[..., 0], n[..., 2] = np.sin(tilt), np.cos(tilt)
    grey = np.full((s, s, 3), 0.25)
    red = np.zeros((s, s, 3))
    red[..., 0] = 1.0
    p = realism.pixel_samples(grey, np.full((s, s, 3), 0.04), np.full((s, s, 1), 0.7), n)
    assert all(v.shape == (realism.GRID ** 2,) for v in p.values())  # a fixed grid whatever the map size
    np.testing.assert_allclose(p["diffuse_luminance"], 0.25)
    np.testing.assert_allclose(p["diffuse_chroma"], 0.0, atol=0.01)  # grey (0.005: whitepoint rounding)
    np.testing.assert_allclose(p["specular_f0"], 0.04)
    np.testing.assert_allclose(p["roughness"], 0.7)
    np.testing.assert_allclose(p["normal_tilt_deg"], 30.0, atol=1e-3)
    # sRGB red primary: L* 53.24, a* 80.09, b* 67.20 -> C*ab 104.55 (CIE D65)
    np.testing.assert_allclose(realism.pixel_samples(red, grey, grey[..., :1], n)["diffuse_chroma"], 104.55, atol=0.05)


def test_pixel_grid_spans_the_whole_map():
    """At 100² (not a multiple of the grid) the 64² grid still covers both halves of a half-0, half-1 map."""
    s = 100
    r = np.zeros((s, s, 1))
    r[:, s // 2:] = 1.0
    flat = np.zeros((s, s, 3))
    flat[..., 2] = 1
    p = realism.pixel_samples(np.zeros((s, s, 3)), np.zeros((s, s, 3)), r, flat)
    assert p["roughness"].mean() == pytest.approx(0.5)


def profile_of(pix: np.ndarray, per: np.ndarray, octs: np.ndarray, name: str = "p") -> Profile:
    """A profile with every pixel statistic equal to ``pix`` (M, P), every per-material one ``per`` (M,)."""
    return Profile(name, "variants", 256, {k: pix for k in realism.PIXEL_STATS},
                   {k: per for k in (*realism.VARIATION_STATS, *realism.CORRELATION_STATS)}, octs)


def test_wasserstein_of_shifted_distributions_is_the_shift():
    rng = np.random.default_rng(2)
    pix, per = rng.random((6, 100)), rng.random(6)
    octs = np.tile(np.eye(7)[0], (6, 1))
    a = profile_of(pix, per, octs)
    b = profile_of(pix + 0.125, per - 0.3, np.tile(np.eye(7)[3], (6, 1)))
    d = distances(a, b)
    for k in realism.PIXEL_STATS:
        assert d[k] == pytest.approx(0.125)
    for k in (*realism.VARIATION_STATS, *realism.CORRELATION_STATS):
        assert d[k] == pytest.approx(0.3)
    assert d[OCTAVE_STAT] == pytest.approx(2.0)  # all power in octave 0 against all in octave 3
    assert all(v == pytest.approx(0.0) for v in distances(a, a).values())


def test_flat_materials_stay_out_of_the_mean_octave_shares():
    octs = np.array([np.eye(7)[2], np.zeros(7)])
    a = profile_of(np.zeros((2, 4)), np.zeros(2), octs)
    b = profile_of(np.zeros((1, 4)), np.zeros(1), np.eye(7)[2][None])
    assert distances(a, b)[OCTAVE_STAT] == pytest.approx(0.0)


def test_noise_floor_split_is_deterministic_given_its_seed():
    a = split_halves(11, 4, seed=3)
    b = split_halves(11, 4, seed=3)
    assert all((x == y).all() and (u == v).all() for (x, u), (y, v) in zip(a, b))
    for x, u in a:
        assert len(x) == len(u) == 5 and not set(x) & set(u)
    assert len({tuple(x) for x, _ in a}) > 1  # the splits differ from each other
    assert any((x != y).any() for (x, _), (y, _) in zip(a, split_halves(11, 4, seed=4)))
    rng = np.random.default_rng(5)
    ref = profile_of(rng.random((11, 50)), rng.random(11), rng.dirichlet(np.ones(7), 11))
    f1, f2 = noise_floor(ref, 4, seed=3), noise_floor(ref, 4, seed=3)
    assert f1 == f2 and f1["roughness"]["mean"] > 0
    # the floor is the mean over splits of the distance between the halves
    want = np.mean([distances(ref.subset(x), ref.subset(u))["roughness"] for x, u in a])
    assert f1["roughness"]["mean"] == pytest.approx(want)
