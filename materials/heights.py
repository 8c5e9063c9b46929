"""Height-field helpers for relief with a set slope: the organic and sheet classes (paper, cork, rubber, bark, knit,
metal_sheet) build each relief layer as a shape, then give it an RMS slope, so the tilt of a preset is a number in
its table rather than a side effect of the shape's amplitude (issue #23: relief at mid scales, fine detail a
minority of the slope power)."""
from __future__ import annotations

import numpy as np

from functools import lru_cache

import scipy.fft as sfft

from .noise import F32, Tex, _freqs, fbm, height_slopes, white_spectrum


def slope_rms(h: np.ndarray) -> float:
    """RMS slope sqrt(mean((dh/dx)^2 + (dh/dy)^2)) of a periodic height map (H, W) in texture widths."""
    sx, sy = height_slopes(h)
    return float(np.sqrt(np.mean(sx.astype(np.float64) ** 2 + sy.astype(np.float64) ** 2)))


def at_slope(h: np.ndarray, rms: float) -> np.ndarray:
    """``h`` (H, W) rescaled to an RMS slope of ``rms`` (a flat field stays flat). Returns (H, W) float32."""
    s = slope_rms(h)
    return (h * F32(rms / s)).astype(F32) if s > 1e-12 else np.zeros_like(h, F32)


@lru_cache(maxsize=64)
def _band_amp(size: int, cycles: float, width: float) -> np.ndarray:
    """Log-Gaussian band amplitude of :func:`materials.noise.band_field`, normalised; cached (a preset asks for
    the same few bands every time, and the log/exp over the grid costs as much as the FFT)."""
    kx, ky = _freqs(size)
    f = np.sqrt(kx * kx + ky * ky)
    amp = np.exp(-0.5 * (np.log(np.maximum(f, 1e-6) / cycles) / width) ** 2)
    amp[0, 0] = 0.0
    amp = (amp / max(float(np.sqrt(np.sum(amp.astype(np.float64) ** 2))), 1e-30)).astype(F32)
    amp.flags.writeable = False
    return amp


def band_pair(size: int, seed: int, c1: float, c2: float, width: float = 0.35) -> tuple[np.ndarray, np.ndarray]:
    """Two independent band-limited fields (like :func:`materials.noise.band_field`) around ``c1`` and ``c2``
    cycles per texture width from ONE white spectrum: the real part of one filtered copy and the imaginary part
    of the other are independent (Hermitian and anti-Hermitian halves of the white noise). Returns two (H, W)
    float32, zero mean, unit variance (expected)."""
    w = white_spectrum(size, seed)
    a = sfft.ifft2(w * _band_amp(size, round(float(c1), 2), width), norm="forward", workers=1).real
    b = sfft.ifft2(w * _band_amp(size, round(float(c2), 2), width), norm="forward", workers=1).imag
    return a.astype(F32), b.astype(F32)


def bands(tex: Tex, mid_cycles: float, mid_slope: float, fine_slope: float, fine_cycles: float = 48.0) -> np.ndarray:
    """Undulation plus grain: one relief band at ``mid_cycles`` per texture width with RMS slope ``mid_slope``,
    and a finer one at ``fine_cycles`` with ``fine_slope`` (keep it the smaller: the network learns mid scales).

    One seed is drawn even when both slopes are 0, so later layers keep theirs.

    Returns:
        (H, W) float32 height in texture widths.
    """
    seed = tex.seed()
    if mid_slope <= 0 and fine_slope <= 0:
        return np.zeros((tex.size, tex.size), F32)
    a, b = band_pair(tex.size, seed, mid_cycles, fine_cycles)
    return (at_slope(a, mid_slope) + at_slope(b, fine_slope)).astype(F32)


def dome(d: np.ndarray, radius: float) -> np.ndarray:
    """A round bump profile sqrt(1 - (d / radius)^2), 0 outside ``radius``; d (H, W) a distance. float32."""
    return np.sqrt(np.clip(1.0 - (d / max(radius, 1e-6)) ** 2, 0.0, 1.0)).astype(F32)


#: the distribution of :func:`independent_relief` (issue #22: relief that owes nothing to the albedo):
#: largest feature 1/16 .. 1/2 texture width (log-uniform), spectral slope of the height power BETA (slope power per
#: octave grows with frequency below 4, falls above), anisotropic (grooves, brushing, strata) with probability
#: ANISO_P, RMS slope log-uniform in SLOPE (the reference's materials span ~0.02 for polished stone to ~0.3 for rock).
INDEPENDENT_SCALE = (1 / 16, 1 / 2)
INDEPENDENT_BETA = (3.0, 4.5)
INDEPENDENT_ANISO_P, INDEPENDENT_ANISO = 0.3, (1.5, 4.0)
INDEPENDENT_SLOPE = (0.03, 0.3)


def independent_relief(size: int, seed: int) -> np.ndarray:
    """A random height field drawn from its own seed, unrelated to any material's colour: an fBm surface whose
    feature size, spectral slope, anisotropy and RMS slope are drawn from the ``INDEPENDENT_*`` ranges above.

    Returns:
        (size, size) float32 height in texture widths.
    """
    rng = np.random.default_rng(seed)
    lo, hi = np.log(INDEPENDENT_SCALE)
    scale = float(np.exp(rng.uniform(lo, hi)))
    beta = float(rng.uniform(*INDEPENDENT_BETA))
    aniso, angle = 1.0, 0.0
    if rng.random() < INDEPENDENT_ANISO_P:
        aniso, angle = float(rng.uniform(*INDEPENDENT_ANISO)), float(rng.uniform(0.0, np.pi))
    lo, hi = np.log(INDEPENDENT_SLOPE)
    rms = float(np.exp(rng.uniform(lo, hi)))
    h = fbm(size, int(rng.integers(0, 2**63 - 1)), scale, beta, aniso=aniso, angle=angle)
    return at_slope(h, rms)
