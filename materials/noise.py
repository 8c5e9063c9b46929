"""Seamlessly tileable noise and patterns on the unit torus, vectorised numpy.

Every function works in *texture space*: u (x, right) and v (row direction,
down) in [0, 1), sampled at pixel centres ``(i + 0.5) / size``. Feature sizes
are given in texture widths, so a 64² and a 1024² map from the same seed show
the same material at two resolutions. Everything is periodic with period 1 in
u and v, so the wrap-around seam is just another pair of neighbouring pixels.

Why spectral synthesis (FFT) and no noise library
-------------------------------------------------
fBm here is built in the frequency domain: complex white noise on the integer
frequency lattice, shaped by an amplitude spectrum, inverse FFT. The inverse
DFT is periodic by construction, so tiling is exact rather than an emulation
(4D torus sampling, blending), and one 256² complex FFT costs ~1 ms, giving
*two* independent fields (real and imaginary parts). Spectra also make
anisotropy (grain, brushing), band limits and octave slopes one line each.
Libraries on PyPI were considered: ``pyfastnoisesimd`` (unmaintained since
2021, no periodic mode), ``pyfastnoiselite`` (no periodic mode),
``noise`` (has ``repeatx/repeaty`` for Perlin but a scalar per-call API, last
release 2015), ``opensimplex-loops`` (tiles by sampling 4D noise: several times
slower than an FFT at these sizes). None beats the FFT at giving exactly periodic
noise, so the module is plain numpy/scipy.

White noise is drawn *per frequency block* (64², then the ring up to 128², ...),
each block from its own seeded generator, so low frequencies are identical at
every resolution: a larger map only adds finer detail.

Height -> normal: ``height_to_normal`` uses central differences with
wrap-around (``np.roll``). Heights are in texture widths. x points right, y
points UP in the image while the row index grows DOWN, so dh/dy = -dh/drow.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.fft as sfft
from scipy import ndimage

F32 = np.float32


class Tex:
    """A texture-space canvas: pixel grid, texture coordinates and a stream of layer seeds.

    Each pattern call takes one fresh seed from ``rng`` (one integer draw), so the
    number of draws never depends on the map size and layers stay independent.

    Args:
        size: map side in pixels.
        rng: the generator of this material instance.
    """

    def __init__(self, size: int, rng: np.random.Generator):
        self.size = int(size)
        self.rng = rng
        self.u, self.v = uv(self.size)

    def seed(self) -> int:
        """A fresh layer seed (one draw from the material's generator)."""
        return int(self.rng.integers(0, 2**63 - 1))

    def sub(self) -> np.random.Generator:
        """A fresh generator for layer-level random choices (positions, per-cell values)."""
        return np.random.default_rng(self.seed())

    # thin conveniences so materials read as recipes
    def fbm(self, scale: float, beta: float = 3.0, **kw) -> np.ndarray:
        return fbm(self.size, self.seed(), scale, beta, **kw)

    def fbm2(self, scale: float, beta: float = 3.0, **kw) -> tuple[np.ndarray, np.ndarray]:
        return fbm_pair(self.size, self.seed(), scale, beta, **kw)

    def blobs(self, scale: float, **kw) -> np.ndarray:
        return fbm(self.size, self.seed(), scale, beta=0.0, gauss=True, **kw)


@lru_cache(maxsize=8)
def uv(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Texture coordinates at pixel centres.

    Returns:
        u, v: (size, size) float32 in (0, 1); u grows with the column, v with the row (downwards).
    """
    t = (np.arange(size, dtype=F32) + 0.5) / size
    u, v = np.meshgrid(t, t)
    u.flags.writeable = v.flags.writeable = False
    return u, v


@lru_cache(maxsize=8)
def _freqs(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Integer frequencies (cycles per texture) in FFT order: kx (columns), ky (rows), each (size, size)."""
    k = np.fft.fftfreq(size, 1.0 / size).astype(F32)
    kx, ky = np.meshgrid(k, k)
    return kx, ky


def white_spectrum(size: int, seed: int) -> np.ndarray:
    """Complex unit white noise on the frequency lattice, resolution-consistent.

    Frequencies |k| < 32 come from block 64, the ring 32..63 from block 128, etc.,
    each block from ``default_rng((seed, block))``.

    Returns:
        (size, size) complex64 in FFT order; real and imaginary parts i.i.d., zero mean, unit variance.
    """
    # the 32-bit codes of the draws, real and imaginary planes; converted to floats once, after the blocks are placed
    codes = np.empty((2, size, size), np.uint32)
    levels = [b for b in (64, 128, 256, 512, 1024) if b <= size]
    if levels[-1] != size:  # sizes between powers of two: one last ring of their own
        levels.append(size)
    inner = 0
    for b in levels:
        # the block is Generator.random((2, b, b), dtype=float32) of default_rng((seed, b)): that draw is
        # (u >> 8) * 2**-24 for the generator's 32-bit outputs u, and PCG64 gives those as the low then the high
        # half of each 64-bit output. So the raw 64-bit stream, viewed as uint32, holds the same draws in the same
        # order, and reading them costs less than the float draw: the whole spectrum 0.87-0.90 -> 0.64 ms at 288²
        # (experiments/sample_speed/results/white_spectrum.json; the same words at 48 sizes x 4 seeds).
        src = np.random.default_rng((seed, b)).bit_generator.random_raw(b * b).view(np.uint32).reshape(2, b, b)
        o = (size - b) // 2
        i0, i1 = (b - inner) // 2, (b - inner) // 2 + inner
        dst = codes[:, o:o + b, o:o + b]
        # the whole block, except the lower-frequency square kept from the previous level (the block's draws
        # there are made and dropped: each level's stream stays the same whatever the size)
        dst[:, :i0], dst[:, i1:] = src[:, :i0], src[:, i1:]
        dst[:, i0:i1, :i0], dst[:, i0:i1, i1:] = src[:, i0:i1, :i0], src[:, i0:i1, i1:]
        inner = b
    codes >>= 8
    # uniform with unit variance: cheaper than normals, and the filtered sum is Gaussian anyway (CLT); the float32
    # steps of the float draw ((u >> 8) * 2**-24, exact), then - 0.5 and * sqrt(12), in that order
    w = codes.astype(F32)
    w *= F32(2.0 ** -24)
    w -= F32(0.5)
    w *= _SQRT12
    c = np.empty((size, size), np.complex64)
    c.real, c.imag = w[0], w[1]
    return np.fft.ifftshift(c)


_SQRT12 = F32(np.sqrt(12.0))


def _amplitude(size, scale, beta, aniso, angle, gauss, detail):
    """Filter amplitude on the lattice in FFT order, (size, size) float32 of unit sum of squares.

    The filter is even, amp(-k) == amp(k) exactly (negating k negates a and b exactly), so for even sizes rows
    0..size/2 are computed and the others mirrored, except the Nyquist column (kx = -size/2 has no +size/2 on the
    lattice), computed as well: half the power and exp evaluations, the same bytes.
    """
    kx, ky = _freqs(size)
    if size % 2:
        amp = _amplitude_at(kx, ky, scale, beta, aniso, angle, gauss, detail)
    else:
        n2 = size // 2
        top = _amplitude_at(kx[:n2 + 1], ky[:n2 + 1], scale, beta, aniso, angle, gauss, detail)
        # row r > size/2 is row size - r with columns j -> (size - j) % size
        bottom = top[n2 - 1:0:-1][:, _mirror_columns(size)]
        bottom[:, n2] = _amplitude_at(kx[n2 + 1:, n2], ky[n2 + 1:, n2], scale, beta, aniso, angle, gauss, detail)
        amp = np.concatenate([top, bottom])
    amp[0, 0] = 0.0  # zero mean
    tot = np.sqrt(np.sum(amp.astype(np.float64) ** 2))
    return (amp / max(tot, 1e-30)).astype(F32)


def _amplitude_at(kx, ky, scale, beta, aniso, angle, gauss, detail):
    """The unnormalised filter of :func:`_amplitude` at frequencies ``kx``, ``ky`` (any one shape), float64."""
    ca, sa = np.cos(angle), np.sin(angle)
    a = kx * ca + ky * sa  # along `angle`
    b = -kx * sa + ky * ca
    # aniso > 1 stretches features along `angle` (fewer cycles along it)
    f2 = (a * aniso) ** 2 + (b / aniso) ** 2
    f0 = 1.0 / max(scale, 1e-6)
    if gauss:  # smooth blobs of about `scale`
        amp = np.exp(-0.5 * f2 / (f0 * f0 * 0.25))
    else:  # fBm: power ~ (f0^2 + f^2)^(-beta/2), flat below f0
        amp = (f0 * f0 + f2) ** (-beta / 4.0)
    if detail is not None:  # finest feature size, in texture widths
        amp = amp * np.exp(-f2 * (detail * detail))
    return amp


@lru_cache(maxsize=8)
def _mirror_columns(size: int) -> np.ndarray:
    """Column index of -k for each column k of the FFT-order lattice: (size - j) % size, (size,) int."""
    return (size - np.arange(size)) % size


def fbm_pair(size: int, seed: int, scale: float, beta: float = 3.0, aniso: float = 1.0, angle: float = 0.0,
             gauss: bool = False, detail: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Two independent periodic Gaussian fields with the same spectrum.

    Args:
        size: map side in pixels.
        seed: layer seed.
        scale: largest feature size in texture widths (spectrum flat below 1/scale).
        beta: spectral slope of the power; 2 rough ... 4 smooth.
        aniso: > 1 stretches features along ``angle`` (radians, from +u towards +v).
        gauss: a Gaussian spectrum (smooth blobs of ~scale) instead of fBm.
        detail: optional finest feature size in texture widths (a low-pass).

    Returns:
        two (size, size) float32 fields, zero mean, unit variance (expected).
    """
    amp = _amplitude(size, float(scale), float(beta), float(aniso), float(angle), gauss, detail)
    f = sfft.ifft2(white_spectrum(size, seed) * amp, norm="forward", workers=1)
    # real and imag parts of complex white noise through a real filter: each has variance sum(amp^2)
    return f.real.astype(F32), f.imag.astype(F32)


def fbm(size: int, seed: int, scale: float, beta: float = 3.0, **kw) -> np.ndarray:
    """One periodic Gaussian field (see :func:`fbm_pair`). Returns (size, size) float32."""
    return fbm_pair(size, seed, scale, beta, **kw)[0]


def blur(img: np.ndarray, sigma: float) -> np.ndarray:
    """Periodic Gaussian blur; ``sigma`` in texture widths. img: (H, W) or (H, W, C)."""
    size = img.shape[0]
    s = sigma * size
    if s < 0.3:
        return img.astype(F32)
    return ndimage.gaussian_filter(img.astype(F32), (s, s) + (0,) * (img.ndim - 2), mode="wrap")


def warp(field: np.ndarray, du: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """Sample ``field`` (H, W) at (u + du, v + dv) with wrap-around; du, dv in texture widths."""
    n = field.shape[0]
    r = np.arange(n, dtype=F32)
    rows = r[:, None] + dv * n
    cols = r[None, :] + du * n
    return ndimage.map_coordinates(field, [rows, cols], order=1, mode="grid-wrap").astype(F32)


def normalize01(x: np.ndarray) -> np.ndarray:
    """Affine map of a field to [0, 1] using the field's own min/max (float32)."""
    lo, hi = float(x.min()), float(x.max())
    return ((x - lo) / max(hi - lo, 1e-12)).astype(F32)


def smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    """Hermite step from 0 at ``e0`` to 1 at ``e1`` (``e1 < e0`` gives a falling step). float32."""
    d = e1 - e0
    d = d if abs(d) > 1e-9 else 1e-9
    t = np.clip((x - e0) * (1.0 / d), 0.0, 1.0)
    return (t * t * (3 - 2 * t)).astype(F32)


def height_to_normal(h: np.ndarray, strength: float = 1.0) -> np.ndarray:
    """Tangent-space normals from a periodic height map by wrapped central differences.

    Args:
        h: (H, W) heights in texture widths (a bump of 0.01 is 1 % of the texture width tall).
        strength: multiplies the slopes.

    Returns:
        (H, W, 3) float32 unit normals, z > 0; x right, y up (row index grows downwards,
        hence dh/dy = -(h[row+1] - h[row-1]) / (2 px)).
    """
    n = h.shape[0]
    k = F32(strength * n / 2.0)  # 1 / (2 px) with px = 1/n texture widths
    dhdx = _wrapped_difference(h, 1) * k
    dhdy = -_wrapped_difference(h, 0) * k
    out = np.empty(h.shape + (3,), F32)
    inv = 1.0 / np.sqrt(dhdx * dhdx + dhdy * dhdy + 1.0)
    out[..., 0] = -dhdx * inv
    out[..., 1] = -dhdy * inv
    out[..., 2] = inv
    return out


def band_field(size: int, seed: int, cycles: float, width: float = 0.35) -> np.ndarray:
    """A periodic Gaussian field whose power sits in one band of spatial frequency.

    Args:
        size: map side in pixels.
        seed: layer seed (the resolution-consistent white noise of :func:`white_spectrum`).
        cycles: centre of the band, cycles per texture width.
        width: standard deviation of the band in natural-log frequency (0.35: about one octave wide).

    Returns:
        (size, size) float32, zero mean, unit variance (expected).
    """
    return sfft.ifft2(white_spectrum(size, seed) * _band_amplitude(size, float(cycles), float(width)),
                      norm="forward", workers=1).real.astype(F32)


@lru_cache(maxsize=32)
def _band_amplitude(size: int, cycles: float, width: float) -> np.ndarray:
    """The filter of :func:`band_field`, (size, size) float32 in FFT order, unit sum of squares; read-only (cached:
    most bands are constants of a class or of the stage's relief, so a variant rarely computes its own)."""
    kx, ky = _freqs(size)
    f = np.sqrt(kx * kx + ky * ky)
    with np.errstate(divide="ignore"):
        amp = np.exp(-0.5 * (np.log(np.maximum(f, 1e-6) / cycles) / width) ** 2)
    amp[0, 0] = 0.0
    amp = (amp / max(float(np.sqrt(np.sum(amp.astype(np.float64) ** 2))), 1e-30)).astype(F32)
    amp.flags.writeable = False
    return amp


def height_slopes(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(dh/dx, dh/dy) of a periodic height map (H, W) in texture widths, by the wrapped central differences of
    :func:`height_to_normal`; y points up in the image, so dh/dy = -dh/drow. Returns two (H, W) float32."""
    k = F32(h.shape[0] / 2.0)
    dhdx = _wrapped_difference(h, 1) * k
    dhdy = -_wrapped_difference(h, 0) * k
    return dhdx.astype(F32), dhdy.astype(F32)


def _wrapped_difference(h: np.ndarray, axis: int) -> np.ndarray:
    """h[i + 1] - h[i - 1] along ``axis`` (0 or 1) of an (H, W) map, wrapping around: the value of
    ``np.roll(h, -1, axis) - np.roll(h, 1, axis)`` without its two copies of ``h``."""
    h = np.asarray(h)
    d = np.empty(h.shape, np.result_type(h, h))
    if axis == 1:
        np.subtract(h[:, 2:], h[:, :-2], out=d[:, 1:-1])
        np.subtract(h[:, 1], h[:, -1], out=d[:, 0])
        np.subtract(h[:, 0], h[:, -2], out=d[:, -1])
    else:
        np.subtract(h[2:], h[:-2], out=d[1:-1])
        np.subtract(h[1], h[-1], out=d[0])
        np.subtract(h[0], h[-2], out=d[-1])
    return d


def add_height(normal: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Normals of a surface raised by the height ``h`` on top of the relief that ``normal`` already shows.

    Slopes add: a normal (nx, ny, nz) is the surface of slopes (-nx/nz, -ny/nz) (:func:`height_to_normal`), so the
    sum of two height fields has the normal of the summed slopes.

    Args:
        normal: (H, W, 3) unit normals, z > 0.
        h: (H, W) heights in texture widths.

    Returns:
        (H, W, 3) float32 unit normals.
    """
    sx, sy = height_slopes(h)
    nz = np.maximum(normal[..., 2], F32(1e-3))
    gx = -normal[..., 0] / nz + sx
    gy = -normal[..., 1] / nz + sy
    inv = 1.0 / np.sqrt(gx * gx + gy * gy + 1.0)
    return np.stack([-gx * inv, -gy * inv, inv], -1).astype(F32)


def band_relief(size: int, seed: int, cycles: float, slope_rms: float) -> np.ndarray:
    """A height field (H, W) in texture widths with its relief in one band around ``cycles`` per texture width,
    scaled so that its RMS slope (sqrt of mean (dh/dx)^2 + (dh/dy)^2, finite differences) is ``slope_rms``."""
    h = band_field(size, seed, cycles)
    sx, sy = height_slopes(h)
    rms = float(np.sqrt(np.mean(sx.astype(np.float64) ** 2 + sy.astype(np.float64) ** 2)))
    return (h * F32(slope_rms / max(rms, 1e-12))).astype(F32)
