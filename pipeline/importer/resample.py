"""Centre square crop and area-averaged resampling to the output size.

Downsampling averages the source pixels each output pixel covers (exact block means for integer factors; for
other factors a separable matrix of exact fractional coverage -- Pillow's BOX filter weighs whole pixels by
their centres, 1.6 % off on a sine at 96 -> 64): no output pixel mixes texels across the tile's border,
so a tileable square source stays tileable. Upsampling (only with ``allow_upscale``) is periodic bilinear
(scipy.ndimage.zoom with ``grid-wrap``), also tileable. A non-square source is centre-cropped to a square and
cannot tile any more; that is recorded.
"""
from __future__ import annotations

import numpy as np


def centre_square(a: np.ndarray) -> np.ndarray:
    """The centred largest square of (H, W, C)."""
    h, w = a.shape[:2]
    s = min(h, w)
    r0, c0 = (h - s) // 2, (w - s) // 2
    return a[r0:r0 + s, c0:c0 + s]


def window(a: np.ndarray, fraction: float, centre: tuple[float, float] = (0.5, 0.5)) -> np.ndarray:
    """The square window of a square (S, S, C) array whose side is ``fraction`` of S (rounded, at least 1 pixel),
    centred at ``centre`` = (x, y) fractions of the side (x right, y down), moved inside the array where it would
    leave it. Maps of one material at different resolutions get the same window of the surface (up to rounding)."""
    s = a.shape[0]
    w = max(1, min(s, int(round(fraction * s))))
    if w == s:
        return a
    c0 = min(max(int(round(centre[0] * s - w / 2)), 0), s - w)
    r0 = min(max(int(round(centre[1] * s - w / 2)), 0), s - w)
    return a[r0:r0 + w, c0:c0 + w]


def coverage(s: int, n: int) -> np.ndarray:
    """(n, s) float32: the fraction of output pixel i's footprint [i s/n, (i+1) s/n) that source pixel j covers."""
    a = np.arange(n)[:, None] * (s / n)
    j = np.arange(s)[None, :]
    overlap = np.clip(np.minimum(a + s / n, j + 1) - np.maximum(a, j), 0, None)
    return (overlap / (s / n)).astype(np.float32)


def resize(a: np.ndarray, size: int) -> np.ndarray:
    """(S, S, C) float32 or integer codes -> (size, size, C) float32, area average down, periodic bilinear up."""
    s = a.shape[0]
    if s == size:
        return a.astype(np.float32)
    if s > size and s % size == 0:
        f, c = s // size, a.shape[2]
        # two contiguous partial sums (rows, then columns) are ~6x faster than one mean over axes (1, 3)
        rows = a.reshape(size, f, s * c).sum(1, dtype=np.float32)
        return (rows.reshape(size, size, f, c).sum(2, dtype=np.float32) / np.float32(f * f)).astype(np.float32)
    a = a.astype(np.float32, copy=False)
    if s > size:
        w = coverage(s, size)
        return np.einsum("ij,jkc,lk->ilc", w, a, w, optimize=True).astype(np.float32)
    from scipy.ndimage import zoom

    return zoom(a, (size / s, size / s, 1), order=1, mode="grid-wrap", grid_mode=True).astype(np.float32)
