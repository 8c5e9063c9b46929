"""Noise and pattern primitives: periodicity, statistics, orientation of normals, colour decoding."""
from __future__ import annotations

import numpy as np
import pytest

from materials.color import linear_to_srgb, srgb_to_linear
from materials.noise import Tex, blur, fbm, fbm_pair, height_to_normal, warp
from materials.patterns import rings, scratches, tiles, weave, worley


def seam_stats(a: np.ndarray, axis: int) -> tuple[float, float]:
    """How the wrap seam compares with the interior pairs of adjacent pixel lines along ``axis``.

    For each adjacent pair of lines (rows for axis 0, columns for axis 1) take the mean |difference|;
    the seam is the pair (last, first).

    Args:
        a: (H, W) or (H, W, C) map.

    Returns:
        ratio: seam statistic / largest interior one (<= 1: no worse than some interior pair).
        z: (seam - interior mean) / interior std.
    """
    a = np.asarray(a, np.float64)
    d = np.abs(np.diff(a, axis=axis))
    other = tuple(i for i in range(a.ndim) if i != axis)
    interior = d.mean(axis=other)
    first = np.take(a, 0, axis=axis)
    last = np.take(a, -1, axis=axis)
    seam = np.abs(first - last).mean()
    return float(seam / max(interior.max(), 1e-9)), float((seam - interior.mean()) / max(interior.std(), 1e-9))


def seam_ok(a: np.ndarray) -> bool:
    """Both seams (rows and columns) statistically like interior pairs: ratio <= 1.05 and z <= 5."""
    return all(r <= 1.05 and z <= 5 for r, z in (seam_stats(a, 0), seam_stats(a, 1)))


def seam_ratio(a: np.ndarray, axis: int) -> float:
    return seam_stats(a, axis)[0]


def test_seam_check_detects_a_cropped_texture():
    # a crop of a periodic field is not periodic: the check must flag it (so the check can fail)
    big = fbm(128, 7, 0.1)
    assert not seam_ok(big[:, :96]) and not seam_ok(big[:96, :])  # either broken seam alone is caught
    assert seam_ok(big)


@pytest.mark.parametrize("size", [64, 100, 128])
def test_fbm_periodic_zero_mean_unit_var(size):
    a, b = fbm_pair(size, 3, 0.2, beta=3.0)
    for f in (a, b):
        assert f.dtype == np.float32 and f.shape == (size, size)
        assert abs(f.mean()) < 0.05  # the DC term is zero
        assert 0.5 < f.std() < 1.5
        assert seam_ok(f)
    assert abs(np.corrcoef(a.ravel(), b.ravel())[0, 1]) < 0.2  # real and imaginary parts independent


def test_fbm_is_resolution_consistent():
    # same seed at 64 and 256: same low frequencies, so the box-downsampled large map matches the small one
    small = fbm(64, 11, 0.25)
    large = fbm(256, 11, 0.25).reshape(64, 4, 64, 4).mean((1, 3))
    assert np.corrcoef(small.ravel(), large.ravel())[0, 1] > 0.9


def test_fbm_anisotropy_stretches_along_angle():
    f = fbm(128, 5, 0.3, aniso=8.0, angle=np.pi / 2)  # stretched along v (down the image)
    dv = np.abs(np.diff(f, axis=0)).mean()
    du = np.abs(np.diff(f, axis=1)).mean()
    assert du > 3 * dv


def test_height_to_normal_orientation():
    n = 64
    v = (np.arange(n) + 0.5) / n
    # a smooth periodic ridge around the middle row: rising from the top edge to the middle row
    h = 0.01 * np.sin(np.pi * v)[:, None] * np.ones((1, n))
    nm = height_to_normal(h.astype(np.float32))
    assert np.allclose(np.linalg.norm(nm, axis=-1), 1, atol=1e-5) and (nm[..., 2] > 0).all()
    # upper half (small rows) rises towards the image bottom -> faces up the image: y > 0
    assert (nm[5:25, :, 1] > 0).all() and (nm[40:60, :, 1] < 0).all()
    assert np.abs(nm[..., 0]).max() < 1e-6
    # columns: a ridge in the middle column; left of it the surface faces left (x < 0)
    hx = h.T.copy()
    nx = height_to_normal(hx.astype(np.float32))
    assert (nx[:, 5:25, 0] < 0).all() and (nx[:, 40:60, 0] > 0).all()
    # strength scales the slope
    assert np.abs(height_to_normal(h.astype(np.float32), 2.0)[..., 1]).max() > np.abs(nm[..., 1]).max()


def test_worley_matches_brute_force_with_wrap():
    tex = Tex(64, np.random.default_rng(1))
    f1, f2, cell, rnd = worley(tex, 5, 1.0)
    g = np.random.default_rng(np.random.default_rng(1).integers(0, 2**63 - 1))
    jx = 0.5 + (g.random((5, 5), dtype=np.float32) - 0.5)
    jy = 0.5 + (g.random((5, 5), dtype=np.float32) - 0.5)
    g.random(25, dtype=np.float32)  # per-cell values
    ox, oy = g.random(2)  # grid offset (cells)
    pts = np.stack([((np.arange(5)[None, :] + jx - ox) / 5).ravel(), ((np.arange(5)[:, None] + jy - oy) / 5).ravel()], 1)
    dx = np.abs(tex.u.ravel()[:, None] - pts[None, :, 0])
    dy = np.abs(tex.v.ravel()[:, None] - pts[None, :, 1])
    d = np.hypot(np.minimum(dx, 1 - dx), np.minimum(dy, 1 - dy)) * 5  # torus distance, in cell widths
    ds = np.sort(d, 1)
    assert np.abs(ds[:, 0] - f1.ravel()).max() < 1e-5
    assert np.abs(ds[:, 1] - f2.ravel()).max() < 1e-5
    assert (np.argmin(d, 1) == cell.ravel()).all()


def test_patterns_tile():
    tex = Tex(96, np.random.default_rng(2))
    f1, f2, _, _ = worley(tex, 7, 0.9)
    t = tiles(tex, 5, 3, stagger=0.5, gap=0.02, bevel=0.01)
    assert t["ny"] == 4  # rounded to even so staggered rows wrap
    fields = {"worley": f2 - f1, "tiles": t["height"], "rings": np.sin(2 * np.pi * rings(tex, 9, 0.8)),
              "weave": weave(tex, 20, "twill", 0.1, 2)[0], "scratches": blur(scratches(tex, 80, 0.3, 0.5, 0.5), 0.01),
              "warp": warp(fbm(96, 1, 0.2), 0.05 * fbm(96, 2, 0.2), 0.05 * fbm(96, 3, 0.2))}
    for name, f in fields.items():
        assert np.isfinite(f).all(), name
        assert seam_ok(f), (name, seam_stats(f, 0), seam_stats(f, 1))


def test_srgb_decoding_matches_iec_61966():
    x = np.array([0.0, 0.04045, 0.5, 1.0])
    ref = np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)
    assert np.allclose(srgb_to_linear(x), ref, atol=1e-6)
    assert np.allclose(linear_to_srgb(srgb_to_linear(x)), x, atol=1e-5)


def _white_spectrum_by_float_draws(size: int, seed: int) -> np.ndarray:
    """The white spectrum as it was written before #42's speed-up: each block Generator.random((2, b, b),
    dtype=float32), shifted and scaled in float32, placed into interleaved real and imaginary planes."""
    c = np.zeros((size, size), np.complex64)
    parts = c.view(np.float32).reshape(size, size, 2)
    levels = [b for b in (64, 128, 256, 512, 1024) if b <= size]
    if levels[-1] != size:
        levels.append(size)
    inner = 0
    for b in levels:
        w = np.random.default_rng((seed, b)).random((2, b, b), dtype=np.float32)
        w -= np.float32(0.5)
        w *= np.float32(np.sqrt(12.0))
        o = (size - b) // 2
        i0, i1 = (b - inner) // 2, (b - inner) // 2 + inner
        for part in range(2):
            dst, src = parts[o:o + b, o:o + b, part], w[part]
            dst[:i0], dst[i1:] = src[:i0], src[i1:]
            dst[i0:i1, :i0], dst[i0:i1, i1:] = src[i0:i1, :i0], src[i0:i1, i1:]
        inner = b
    return np.fft.ifftshift(c)


@pytest.mark.parametrize("size", [64, 100, 256, 288, 513])
def test_white_spectrum_is_the_float_draws_bit_for_bit(size):
    """white_spectrum reads PCG64's raw 64-bit stream as the 32-bit draws Generator.random(dtype=float32) makes
    from it (low half first, (u >> 8) * 2**-24): every stored variant depends on those being the same floats, so
    the spectrum must equal the float draws' bit for bit (sizes: powers of two, between them, odd; seeds near 0
    and near 2**63)."""
    from materials.noise import white_spectrum

    for seed in (0, 7, 2**63 - 5):
        got, want = white_spectrum(size, seed), _white_spectrum_by_float_draws(size, seed)
        assert got.dtype == want.dtype == np.complex64 and got.shape == want.shape == (size, size)
        differ = int(np.count_nonzero(got.view(np.uint32) != want.view(np.uint32)))
        assert differ == 0, f"size {size}, seed {seed}: {differ} of {2 * size * size} float32 words differ"
