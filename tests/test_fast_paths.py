"""The sped-up paths of sample and blend (#24) give the bytes of the direct formulas they replace.

Each reference below is the formula as it was written before the speed-up (kept here, short and obvious); the
optimised code must agree with it bit for bit, so that stores, ``dvc.lock`` and every recorded figure stay valid.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy import fft as sfft
from scipy.stats import truncnorm

import materials
from materials import noise
from materials.maps import normalize, vector_length
from materials.params import perturb
from pipeline.blend import MIN_NZ, blend_normals

F32 = np.float32
SIZES = (8, 64, 96, 256, 300)


def amplitude_direct(size, scale, beta, aniso, angle, gauss, detail):
    """The filter of noise._amplitude on the whole lattice (no mirroring)."""
    kx, ky = noise._freqs(size)
    ca, sa = np.cos(angle), np.sin(angle)
    a = kx * ca + ky * sa
    b = -kx * sa + ky * ca
    f2 = (a * aniso) ** 2 + (b / aniso) ** 2
    f0 = 1.0 / max(scale, 1e-6)
    amp = np.exp(-0.5 * f2 / (f0 * f0 * 0.25)) if gauss else (f0 * f0 + f2) ** (-beta / 4.0)
    if detail is not None:
        amp = amp * np.exp(-f2 * (detail * detail))
    amp[0, 0] = 0.0
    return (amp / max(np.sqrt(np.sum(amp.astype(np.float64) ** 2)), 1e-30)).astype(F32)


def white_spectrum_direct(size, seed):
    """noise.white_spectrum with complex block temporaries and a copy back of the kept inner square."""
    c = np.zeros((size, size), np.complex64)
    levels = [b for b in (64, 128, 256, 512, 1024) if b <= size]
    if levels[-1] != size:
        levels.append(size)
    inner = 0
    for b in levels:
        w = np.random.default_rng((seed, b)).random((2, b, b), dtype=F32)
        w -= F32(0.5)
        w *= F32(np.sqrt(12.0))
        o = (size - b) // 2
        blk = w[0] + 1j * w[1]
        if inner:
            i0 = (b - inner) // 2
            blk[i0:i0 + inner, i0:i0 + inner] = c[o + i0:o + i0 + inner, o + i0:o + i0 + inner]
        c[o:o + b, o:o + b] = blk
        inner = b
    return np.fft.ifftshift(c)


def band_field_direct(size, seed, cycles, width=0.35):
    kx, ky = noise._freqs(size)
    f = np.sqrt(kx * kx + ky * ky)
    with np.errstate(divide="ignore"):
        amp = np.exp(-0.5 * (np.log(np.maximum(f, 1e-6) / float(cycles)) / width) ** 2)
    amp[0, 0] = 0.0
    amp = (amp / max(float(np.sqrt(np.sum(amp.astype(np.float64) ** 2))), 1e-30)).astype(F32)
    return sfft.ifft2(white_spectrum_direct(size, seed) * amp, norm="forward", workers=1).real.astype(F32)


def same_bytes(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("size", SIZES)
def test_the_mirrored_filter_is_the_filter_on_the_whole_lattice(size):
    """Half the lattice computed, the rest mirrored: the Nyquist column has no mirror and must be computed too
    (mirroring it as well changes 1 to 64k values, and through the normalisation every other one)."""
    rng = np.random.default_rng(size)
    for _ in range(25):
        args = (size, float(rng.uniform(0.01, 2)), float(rng.uniform(1, 4)), float(rng.uniform(0.3, 3)),
                float(rng.uniform(0, 2 * np.pi)), bool(rng.random() < 0.3),
                None if rng.random() < 0.5 else float(rng.uniform(0.001, 0.05)))
        got, want = noise._amplitude(*args), amplitude_direct(*args)
        assert same_bytes(got, want), f"{args}: {int(np.sum(got != want))} of {got.size} values differ"


@pytest.mark.parametrize("size", SIZES[1:])  # the lattice starts at block 64
def test_white_spectrum_written_in_place_is_the_block_construction(size):
    for seed in (0, 7, 2**40 + 3):
        assert same_bytes(noise.white_spectrum(size, seed), white_spectrum_direct(size, seed)), (size, seed)


def test_band_field_with_its_cached_filter_is_the_direct_band_field():
    for size, seed, cycles in ((64, 1, 4.0), (256, 2, 64.0), (256, 3, 64.0), (96, 4, 7.3), (256, 5, 4.0)):
        assert same_bytes(noise.band_field(size, seed, cycles), band_field_direct(size, seed, cycles))
    cached = noise._band_amplitude(64, 4.0, 0.35)
    assert not cached.flags.writeable  # a caller cannot change the filter every later call reads


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_wrapped_differences_are_the_rolled_differences(dtype):
    h = np.random.default_rng(0).standard_normal((37, 41)).astype(dtype)
    for axis in (0, 1):
        assert same_bytes(noise._wrapped_difference(h, axis), np.roll(h, -1, axis) - np.roll(h, 1, axis))
    k = F32(h.shape[0] / 2.0)
    sx, sy = noise.height_slopes(h)
    assert same_bytes(sx, ((np.roll(h, -1, 1) - np.roll(h, 1, 1)) * k).astype(F32))
    assert same_bytes(sy, (-(np.roll(h, -1, 0) - np.roll(h, 1, 0)) * k).astype(F32))


def test_normalize_by_channel_is_the_broadcast_division():
    rng = np.random.default_rng(1)
    for shape in ((256, 256, 3), (5, 3), (2, 9, 7, 3)):
        v = rng.standard_normal(shape).astype(F32)
        v.reshape(-1, 3)[0] = 0.0  # a zero vector: divided by eps, not by 0
        want = v / np.maximum(vector_length(v), F32(1e-8))[..., None]
        assert same_bytes(normalize(v), want), shape


@pytest.mark.parametrize("weight", ["float", "float32", "mask"])
def test_blend_normals_by_planes_is_the_slope_formula(weight):
    rng = np.random.default_rng(2)
    na = normalize(rng.standard_normal((64, 48, 3)).astype(F32) + [0, 0, 1.5])
    nb = normalize(rng.standard_normal((64, 48, 3)).astype(F32) * [1, 1, 0.01] + [0, 0, 0.002])  # some nz < MIN_NZ
    w = {"float": 0.37, "float32": F32(0.37), "mask": rng.random((64, 48, 1)).astype(F32)}[weight]
    sa = na[..., :2] / np.maximum(na[..., 2:3], MIN_NZ)
    sb = nb[..., :2] / np.maximum(nb[..., 2:3], MIN_NZ)
    s = w * sa + (1.0 - w) * sb
    want = normalize(np.concatenate([s, np.ones_like(s[..., :1])], axis=-1))
    assert same_bytes(blend_normals(na, nb, w), want)


def test_one_vectorised_perturbation_draw_is_one_draw_per_parameter():
    """Same values, and the generator left in the same state (the variant's map seed is its next draw)."""
    def direct(preset, k, sigma, rng):
        out = {}
        for p in preset.exposed:
            if k == 0 or p.high == p.low:
                v = p.default
            else:
                scale = sigma * (p.high - p.low)
                v = float(truncnorm.rvs((p.low - p.default) / scale, (p.high - p.default) / scale, loc=p.default,
                                        scale=scale, random_state=rng))
            if p.kind == "int":
                v = float(np.clip(np.round(v), p.low, p.high))
            out[p.name] = float(np.clip(v, p.low, p.high))
        return out

    presets = materials.presets()[::7]
    for i, preset in enumerate(presets):
        for k, sigma in ((0, 0.25), (1, 0.25), (2, 0.05), (3, 1.0)):
            r1, r2 = np.random.default_rng(i * 10 + k), np.random.default_rng(i * 10 + k)
            assert perturb(preset, k, sigma, r1) == direct(preset, k, sigma, r2), (preset.name, k)
            assert r1.integers(0, 2**63 - 1) == r2.integers(0, 2**63 - 1), (preset.name, k)
    with pytest.raises(ValueError, match="sigma"):
        perturb(presets[0], 1, 0.0, np.random.default_rng(0))


def test_lerp_and_tint_by_channel_are_the_broadcast_formulas():
    from materials.compose import lerp, tint

    rng = np.random.default_rng(3)
    t = rng.random((40, 30)).astype(F32)
    field = rng.standard_normal((40, 30)).astype(F32)
    maps = rng.random((40, 30, 3)).astype(F32)
    colour = np.array([0.2, 0.5, 0.7])  # float64 in: converted as before
    for a, b in ((colour, maps), (maps, colour), (maps, maps[::-1].copy()), (colour, colour[::-1])):
        want = (np.asarray(a, F32) * (1 - t[..., None]) + np.asarray(b, F32) * t[..., None]).astype(F32)
        assert same_bytes(lerp(a, b, t), want)
    assert same_bytes(lerp(maps, colour, 0.25), (maps * (1 - F32(0.25)) + colour.astype(F32) * F32(0.25)))
    for c in (colour, maps):
        want = (np.asarray(c, F32) * np.exp(F32(0.3) * field)[..., None]).astype(F32)
        assert same_bytes(tint(c, field, 0.3), want)
