"""Shape handling against an independent oracle: the normals of a transformed height field (#22).

Every place that moves a normal map (training augmentation, the render's view transform, the extra relief of
``svgen sample``) must give the normals that the moved *height* has. ``height_to_normal`` of the moved height is
the oracle: it shares no rotation code with the transforms, so a normal turned the wrong way, a flip that forgets
to negate x, or a slope with the wrong sign shows up as a mismatch of order one.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from materials.maps import SVBRDF, pack_maps
from materials.noise import add_height, band_relief, height_slopes, height_to_normal
from train.data import augment

N = 32
#: generator seeds whose augmentation draws are the 8 rotation/flip cases, one each (checked below).
AUG_SEEDS = (0, 1, 2, 4, 8, 11, 14, 24)


def smooth_height(n: int = N, amp: float = 0.02) -> np.ndarray:
    """A periodic, asymmetric height (no rotation or mirror symmetry), in texture widths: (n, n) float32."""
    t = 2 * np.pi * (np.arange(n) + 0.5) / n
    u, v = np.meshgrid(t, t)  # u along columns, v along rows (down)
    return (amp * (np.sin(u) + 0.6 * np.cos(2 * v + 0.3) + 0.4 * np.sin(u + v) + 0.3 * np.cos(u - 2 * v))
            ).astype(np.float32) / (2 * np.pi)


def maps_of(h: np.ndarray) -> SVBRDF:
    n = h.shape[0]
    grey = np.full((n, n, 3), 0.5, np.float32)
    return SVBRDF(height_to_normal(h), grey, grey * 0.1, np.full((n, n, 1), 0.5, np.float32))


@pytest.mark.parametrize("seed", AUG_SEEDS)
def test_augmented_normals_are_the_normals_of_the_augmented_height(seed):
    """The height rides along as an image channel (the crop is the whole map, so only rotations/flips act)."""
    h = smooth_height()
    img = np.repeat(h[..., None], 3, -1)
    a_img, a_maps = augment(img, pack_maps(maps_of(h)), np.random.default_rng(seed), crop=N)
    np.testing.assert_allclose(a_maps[..., 0:3], height_to_normal(np.ascontiguousarray(a_img[..., 0])), atol=1e-5)


def test_the_augmentations_drawn_cover_every_rotation_and_flip():
    """AUG_SEEDS draw all 8 rotation/flip cases (else a broken case could hide)."""
    h = smooth_height()
    img = np.repeat(h[..., None], 3, -1)
    seen = {augment(img, img, np.random.default_rng(s), crop=N)[0][..., 0].tobytes() for s in AUG_SEEDS}
    assert len(seen) == 8


@pytest.mark.parametrize("rotation", [math.pi / 2, math.pi, 3 * math.pi / 2, 0.6])
def test_view_normals_are_the_normals_of_the_viewed_height(rotation):
    """The render's view transform (zoom 1: slopes keep their size) carries the height in the diffuse map; the view's
    normals must be the normals of that rotated height. Quarter turns hit texel centres (exact up to float); 0.6 rad
    interpolates bilinearly, hence the looser tolerance (the wrong direction misses by ~0.1)."""
    pytest.importorskip("mitsuba")
    from storage.views import ViewParams, transform_maps

    n = 64
    h = smooth_height(n)
    base = maps_of(h)
    lo, span = float(h.min()), float(h.max() - h.min())
    base.diffuse = np.repeat(((h - lo) / span)[..., None], 3, -1).astype(np.float32)
    out = transform_maps(base, ViewParams(zoom=1.0, rotation=rotation), n)
    h_view = out.diffuse[..., 0] * span + lo
    tol = 2e-4 if abs(rotation / (math.pi / 2) - round(rotation / (math.pi / 2))) < 1e-9 else 6e-3
    # inside the picture only: a view at an odd angle is not periodic, so the oracle's wrapped differences at the
    # picture's edges compare the two opposite edges
    want = height_to_normal(h_view.astype(np.float32))
    np.testing.assert_allclose(out.normal[1:-1, 1:-1], want[1:-1, 1:-1], atol=tol)


def test_height_to_normal_faces_away_from_the_uphill_side():
    """A height rising to the right tilts the normal left (x < 0); rising up the image (towards row 0) tilts it down
    (y < 0): DESIGN.md's x right, y up, with numpy row 0 at the image top."""
    n = N
    t = (np.arange(n) + 0.5) / n
    ramp = 0.01 * np.sin(2 * np.pi * t)  # rising where sin rises: the left quarter of the map
    right = height_to_normal(np.tile(ramp, (n, 1)).astype(np.float32))
    up = height_to_normal(np.tile(ramp[::-1, None], (1, n)).astype(np.float32))  # rising towards row 0 at the top
    assert (right[:, 1:n // 4 - 1, 0] < 0).all() and np.abs(right[..., 1]).max() < 1e-6
    assert (up[n - n // 4 + 1:n - 1, :, 1] < 0).all() and np.abs(up[..., 0]).max() < 1e-6


def test_adding_heights_adds_slopes():
    """add_height on a flat map is height_to_normal; on a relief it is the normal of the summed heights."""
    h1, h2 = smooth_height(), smooth_height().T.copy() * 0.5
    flat = np.zeros((N, N, 3), np.float32)
    flat[..., 2] = 1
    np.testing.assert_allclose(add_height(flat, h1), height_to_normal(h1), atol=1e-6)
    np.testing.assert_allclose(add_height(height_to_normal(h1), h2), height_to_normal(h1 + h2), atol=1e-5)


@pytest.mark.parametrize("cycles", [4.0, 12.0])
def test_band_relief_has_its_slope_and_its_scale(cycles):
    """The RMS slope is the one asked for, and the slope power peaks near the asked band."""
    n = 128
    h = band_relief(n, 3, cycles, 0.2)
    sx, sy = height_slopes(h)
    assert math.isclose(float(np.sqrt(np.mean(sx ** 2 + sy ** 2))), 0.2, rel_tol=1e-4)
    p = np.abs(np.fft.fft2(h)) ** 2
    k = np.fft.fftfreq(n, 1 / n)
    f = np.hypot(*np.meshgrid(k, k))
    slope_power = p * f ** 2
    peak = float((slope_power * f).sum() / slope_power.sum())  # slope-power-weighted mean frequency
    assert cycles * 0.8 < peak < cycles * 1.6


def test_the_rmse_normal_term_is_the_evaluations_normal_column():
    """optim.normal_loss=rmse is exactly what svtrain eval reports, the mean over samples of each sample's normal RMSE
    in the (n+1)/2 encoding, not a pooled error: a perfect sample beside a wrong one halves it."""
    from train.evaluate import metrics
    from train.fit import normal_term

    g = torch.Generator().manual_seed(3)
    t = torch.rand(4, 10, 8, 8, generator=g)
    p = torch.rand(4, 10, 8, 8, generator=g)
    for m in (t, p):
        m[:, 0:3] = torch.nn.functional.normalize(m[:, 0:3] - torch.tensor([0.5, 0.5, 0.0])[:, None, None], dim=1)
    p[0] = t[0]  # one perfect sample
    want = float(np.mean(metrics(p, t)["normal"]))
    # tolerance: the term's 1e-8 under each root adds at most sqrt(1e-8) = 1e-4 (the perfect sample's whole RMSE)
    assert float(normal_term(p, t, "rmse")) == pytest.approx(want, abs=1e-4)
    pooled = float((((p[:, 0:3] - t[:, 0:3]) * 0.5) ** 2).mean().sqrt())
    assert abs(float(normal_term(p, t, "rmse")) - pooled) > 0.01 * pooled  # not the pooled RMSE


def test_the_late_normal_term_takes_over_at_its_share_of_the_run():
    """optim.normal_late_loss: before normal_late_from x iterations the loss holds normal_l2 x the normal_loss form,
    from that step on normal_late_weight x the late form (the rendering term off, so the loss is the normal term)."""
    from train.config import OptimConfig
    from train.fit import loss_terms, normal_term

    g = torch.Generator().manual_seed(5)
    t, p = torch.rand(2, 10, 8, 8, generator=g), torch.rand(2, 10, 8, 8, generator=g)
    o = OptimConfig(iterations=10, render_weight=0, normal_l2=100.0, normal_loss="l2", normal_late_loss="rmse",
                    normal_late_from=0.4, normal_late_weight=30.0)
    early, late = 100.0 * float(normal_term(p, t, "l2")), 30.0 * float(normal_term(p, t, "rmse"))
    assert early != pytest.approx(late)  # the two forms tell the steps apart
    for step, want in ((0, early), (3, early), (4, late), (9, late), (None, early)):
        assert float(loss_terms(p, t, None, g, o, step=step)) == pytest.approx(want, rel=1e-6), step
    # unset: the normal_loss form throughout
    plain = OptimConfig(iterations=10, render_weight=0, normal_l2=100.0)
    assert float(loss_terms(p, t, None, g, plain, step=9)) == pytest.approx(early, rel=1e-6)


def test_the_l2_normal_term():
    """optim.normal_loss=l2: 0 for the true normals; for one tilted pixel the hand-computed value."""
    import torch

    from train.fit import normal_term

    t = torch.zeros(1, 10, 1, 1)
    t[0, 2] = 1.0
    p = t.clone()
    p[0, 0:3, 0, 0] = torch.tensor([0.6, 0.0, 0.8])
    assert float(normal_term(t, t, "l2")) == pytest.approx(0.0, abs=1e-7)
    assert float(normal_term(p, t, "l2")) == pytest.approx(0.6 ** 2 / 2, rel=1e-5)


def test_sample_relief_adds_its_band_to_a_variant_and_nothing_else():
    """svgen sample's relief knob: off leaves the variant as it is; on adds exactly the band's slopes to its normals
    and leaves the other maps alone."""
    from pipeline.sample import Relief
    from svcore.seeds import derive_seed

    m = maps_of(smooth_height(64))
    assert Relief().apply(m, 7) is m
    r = Relief(0.2, 8.0).apply(m, 7)
    np.testing.assert_allclose(r.normal, add_height(m.normal, band_relief(64, derive_seed(7, "sample", 1 << 20), 8.0, 0.2)))
    for k in ("diffuse", "specular", "roughness"):
        assert getattr(r, k) is getattr(m, k)


def test_relief_modes_replace_only_the_normals_in_their_shares():
    """flat_share / swap_share: about their share of variants gets flat normals or an independent relief, drawn from
    each variant's own seed; the other maps are the generator's, untouched."""
    from materials.heights import independent_relief
    from pipeline.sample import Relief
    from svcore.seeds import derive_seed

    m = maps_of(smooth_height(64))
    rel = Relief(flat_share=0.3, swap_share=0.4)
    modes = [rel.mode(s) for s in range(2000)]
    share = {k: modes.count(k) / len(modes) for k in ("flat", "independent", "own")}
    # binomial standard error at n = 2000 is <= 0.011: 4 of them
    assert abs(share["flat"] - 0.3) < 0.045 and abs(share["independent"] - 0.4) < 0.045, share
    for seed in (modes.index("flat"), modes.index("independent"), modes.index("own")):
        r = rel.apply(m, seed)
        for k in ("diffuse", "specular", "roughness"):
            assert getattr(r, k) is getattr(m, k)
        if modes[seed] == "flat":
            np.testing.assert_array_equal(r.normal[..., :2], 0.0)
        elif modes[seed] == "independent":
            flat = np.zeros_like(m.normal)
            flat[..., 2] = 1
            h = independent_relief(64, derive_seed(seed, "sample", (1 << 20) | 2))
            np.testing.assert_allclose(r.normal, add_height(flat, h), atol=1e-6)
            assert np.abs(r.normal - m.normal).max() > 0.05  # not the variant's own relief
        else:
            assert r is m


def test_the_default_library_has_fine_grain_on_presets_variants_only():
    """The default sample config adds the fine grain of #23 (an RMS slope of 0.06 at 64 cycles per map) to a
    preset's variant, with its power in the finest octaves; an imported material's variant (``modes`` False) keeps
    its measured relief untouched."""
    from pipeline.config import SampleConfig
    from pipeline.sample import Relief
    from svcore.config import build

    rel = Relief.of(build(SampleConfig))
    assert (rel.relief, rel.relief_cycles) == (0.06, 64.0)
    m = maps_of(smooth_height(256))
    assert rel.apply(m, 7, modes=False) is m
    seed = next(s for s in range(100) if rel.mode(s) == "own")
    r = rel.apply(m, seed)
    # the added slopes: the grain alone (its heights' RMS slope 0.06), nearly all above 32 cycles per map
    d = r.normal[..., :2] / r.normal[..., 2:3] - m.normal[..., :2] / m.normal[..., 2:3]
    assert 0.04 < float(np.sqrt((d ** 2).sum(-1).mean())) < 0.08
    f = np.abs(np.fft.fft2(d, axes=(0, 1))) ** 2
    k = np.hypot(*np.meshgrid(np.fft.fftfreq(256) * 256, np.fft.fftfreq(256) * 256, indexing="ij"))
    assert f[k >= 32].sum() / f.sum() > 0.9


def test_relief_spread_draws_each_variants_grain_amplitude_log_normally():
    """``sample.relief_spread`` S: a variant's grain has RMS slope relief x exp(S z), z a standard normal of its own
    seed, so the logs of the amplitudes over many variants have standard deviation S around log(relief); at 0 every
    variant gets exactly ``relief`` (the default, whose bytes tests/data/same_bytes.json pins)."""
    from pipeline.sample import Relief

    flat = maps_of(np.zeros((64, 64), np.float32))

    def grain_rms(rel: Relief, seed: int) -> float:
        n = rel.apply(flat, seed).normal
        return float(np.sqrt(((n[..., :2] / n[..., 2:3]) ** 2).sum(-1).mean()))

    seeds = range(200)
    fixed = np.log([grain_rms(Relief(0.06, 16.0), s) for s in seeds])
    assert fixed.std() < 0.02 and abs(np.exp(fixed.mean()) - 0.06) < 0.006  # finite differences vs the normals
    spread = np.log([grain_rms(Relief(0.06, 16.0, relief_spread=0.5), s) for s in seeds])
    # 200 draws: the sample std of a normal with sigma 0.5 lies within 0.5 +- 0.075 (3 standard errors, 0.5/sqrt(400))
    assert abs(spread.std() - 0.5) < 0.075, spread.std()
    assert abs(spread.mean() - fixed.mean()) < 0.11  # 3 standard errors of the mean, 0.5 / sqrt(200)
    # the spread draws from a stream of its own: the grain's pattern is unchanged, only its amplitude
    na, nb = Relief(0.06, 16.0).apply(flat, 3).normal, Relief(0.06, 16.0, relief_spread=0.5).apply(flat, 3).normal
    sa, sb = na[..., :2] / na[..., 2:3], nb[..., :2] / nb[..., 2:3]
    assert abs(np.corrcoef(sa.ravel(), sb.ravel())[0, 1]) > 0.999  # the same field, another amplitude
    assert abs(np.log(np.abs(sb).mean() / np.abs(sa).mean())) > 0.01


def test_relief_patches_vary_the_grain_within_a_material_and_keep_its_rms_slope():
    """``sample.relief_patches`` P: the grain's amplitude varies over the map (h x exp(p g), p ~ U(0, P) per variant),
    rescaled to the same RMS slope. On a flat material a uniform Gaussian grain has the CV of slope magnitude of a
    Rayleigh law (0.52) whatever its amplitude; patches raise it for most variants, and the RMS slope is kept."""
    from pipeline.sample import Relief

    flat = maps_of(np.zeros((128, 128), np.float32))

    def slope_stats(rel: Relief, seed: int) -> tuple[float, float]:
        n = rel.apply(flat, seed).normal
        s = np.hypot(n[..., 0] / n[..., 2], n[..., 1] / n[..., 2])
        return float(s.std() / s.mean()), float(np.sqrt((s ** 2).mean()))

    seeds = range(40)
    uniform = np.array([slope_stats(Relief(0.06, 32.0), s) for s in seeds])
    patchy = np.array([slope_stats(Relief(0.06, 32.0, relief_patches=1.2), s) for s in seeds])
    # Rayleigh CV sqrt(4/pi - 1) = 0.523; 128^2 pixels of a band field at 32 cycles hold ~3,000 independent
    # features, so each map's CV is within a few hundredths of it
    assert np.abs(uniform[:, 0] - 0.523).max() < 0.03
    # p ~ U(0, 1.2): the CV of w x Rayleigh is sqrt(1.27 exp(p^2) - 1), 0.52 at p = 0 and 1.6 at 1.2; half the
    # variants draw p > 0.6 (CV > 0.76)
    assert np.median(patchy[:, 0]) > 0.7 and patchy[:, 0].max() > 1.0 and patchy[:, 0].min() > 0.45
    np.testing.assert_allclose(patchy[:, 1], 0.06, rtol=0.1)  # the RMS slope (of the normals) is kept
    np.testing.assert_allclose(uniform[:, 1], 0.06, rtol=0.1)


def test_flat_variants_stay_flat_without_the_grain_only_when_asked():
    """``flat_grain`` False: a flat-mode variant has exactly flat normals though the library adds its grain to every
    other preset variant (real prints and polished stone are flat; with the grain the library holds no flat
    material). True (the default, the stores before the option): the flat variant gets the grain like the others,
    and the recorded config leaves the key out, so that stores keep their bytes."""
    from pipeline.config import SampleConfig
    from pipeline.sample import Relief
    from svcore.config import build

    m = maps_of(smooth_height(64))
    with_grain = Relief.of(build(SampleConfig))
    flat_only = Relief.of(build(SampleConfig, flat_grain=False))
    assert with_grain.flat_grain and not flat_only.flat_grain
    flat_seed = next(s for s in range(100) if with_grain.mode(s) == "flat")
    own_seed = next(s for s in range(100) if with_grain.mode(s) == "own")
    np.testing.assert_array_equal(flat_only.apply(m, flat_seed).normal[..., :2], 0.0)
    assert np.abs(with_grain.apply(m, flat_seed).normal[..., :2]).max() > 0.01  # the grain on a flat variant
    # every other variant is the same either way
    np.testing.assert_array_equal(flat_only.apply(m, own_seed).normal, with_grain.apply(m, own_seed).normal)
    assert "flat_grain" in build(SampleConfig).dropped_keys()
    assert "flat_grain" not in build(SampleConfig, flat_grain=False).dropped_keys()
