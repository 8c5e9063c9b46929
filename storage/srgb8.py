"""On-disk encoding of rendered images: 8-bit sRGB, like the paper's PNGs, exactly colour-science's curve.

The linear LDR image x in [0, 1] is stored as code = round(255 * srgb_encode(x)) (IEC 61966-2-1, colour-science)
and read back as srgb_decode(code / 255). Calling colour-science per image costs ~190 ms for 256^2 x 3 values
(float64 with domain checks), more than the whole render, so both directions use tables computed once with
colour-science: decoding is a 256-entry lookup; encoding counts the 255 linear thresholds where the code steps
up, srgb_decode((k + 0.5) / 255) -- the curve is monotonic, so the code of x is the number of thresholds <= x,
i.e. colour-science's rounding (tests/test_render_store.py checks it). The count is found in O(1): a uniform
table over 8192 buckets gives the code at each bucket's start, and since thresholds are >= 3e-4 apart (the
steepest part of the curve, 1 / (255 * 12.92)) and buckets 1.2e-4 wide, at most one threshold lies inside a
bucket: one comparison finishes the count (x * 8192 is exact in float32, so x's bucket is exact too;
np.searchsorted took 18 ms per image, this ~2 ms).

Why 8-bit sRGB and not 16-bit linear: the store budget (<= 200 KB per 256^2 view, maps included), and sRGB's
steps are fine where the network's log input transform (log(x + 0.01)) is sensitive: the first code step is
3e-4 linear, against 3.9e-3 for 8-bit linear. The measured round-trip error is in benchmarks/results/render.json.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from svcore.image_io import srgb_decode, srgb_encode

ENCODING = "sRGB IEC 61966-2-1 (colour-science), round(255 * encode(linear)), uint8"


@lru_cache(maxsize=1)
def _thresholds() -> np.ndarray:
    """(255,) float32 linear values where the 8-bit sRGB code steps up (code k -> k+1 at index k)."""
    t = srgb_decode((np.arange(255, dtype=np.float64) + 0.5) / 255.0).astype(np.float64)
    # a float32 input x compares against the threshold as float32 does: round thresholds up to the first
    # float32 >= the exact value so that x >= threshold in float32 iff x >= threshold exactly
    t32 = t.astype(np.float32)
    t32 = np.where(t32.astype(np.float64) < t, np.nextafter(t32, np.float32(2)), t32)
    return t32


_BUCKETS = 8192


@lru_cache(maxsize=1)
def _bucket_codes() -> tuple[np.ndarray, np.ndarray]:
    """(code at the start of each bucket (BUCKETS + 1,), thresholds padded with +inf (256,))."""
    t = _thresholds()
    starts = (np.arange(_BUCKETS + 1, dtype=np.float64) / _BUCKETS).astype(np.float32)
    codes = np.searchsorted(t, starts, side="right").astype(np.int64)
    return codes, np.append(t, np.float32(np.inf)).astype(np.float32)


@lru_cache(maxsize=1)
def decode_lut() -> np.ndarray:
    """(256,) float32 linear value of each 8-bit sRGB code."""
    return srgb_decode(np.arange(256, dtype=np.float64) / 255.0).astype(np.float32)


def encode_srgb8(linear: np.ndarray) -> np.ndarray:
    """Linear [0, 1] float image -> uint8 sRGB codes (same shape). Values outside [0, 1] are clipped."""
    x = np.clip(np.asarray(linear, np.float32), 0.0, 1.0)
    codes, thr = _bucket_codes()
    # x * BUCKETS is exact in float32 (a power of two), so b is x's own bucket; buckets (1.2e-4) are narrower than the
    # closest thresholds (3.0e-4 apart), so at most one threshold lies in [bucket start, x]: one comparison finishes
    # the count (every float32 in [0, 1] checked: experiments/direct_calls/check_encoder_rule.py). The clip only
    # keeps a NaN's index inside the table.
    b = np.clip((x * _BUCKETS).astype(np.int64), 0, _BUCKETS)
    c = codes[b]
    c += x >= thr[c]
    return c.astype(np.uint8)


class DrjitEncoder:
    """The same 8-bit sRGB encoding as :func:`encode_srgb8`, run by drjit on a rendered image that is still a
    drjit array: fused into one multithreaded kernel, no float copy to numpy (~1 ms instead of ~5 ms CPU)."""

    def __init__(self):
        from svcore.mi_env import mi

        codes, thr = _bucket_codes()
        self._mi = mi
        self._codes_lut = mi.UInt32(codes.astype(np.uint32))
        self._thr = mi.Float(thr)

    def __call__(self, linear) -> np.ndarray:
        """drjit Float array (any width) of linear values -> numpy uint8 codes (same order)."""
        return np.asarray(self._codes(self._mi.Float(linear))).astype(np.uint8)

    def channels(self, channels) -> np.ndarray:
        """The channels of an image still being traced (e.g. a render's R, G and B, each a drjit Float of N pixels)
        -> (N, C) numpy uint8 codes, channels side by side.

        The codes are computed in the kernel that computes the channels: the render and its encoding are one
        kernel, and the image's floats are never written to memory (experiments/direct_calls). An interleaved
        float image would need a scatter, which ends the kernel; here each channel's codes are their own output.
        """
        from svcore.mi_env import dr

        codes = [self._mi.UInt8(self._codes(x)) for x in channels]
        dr.eval(*codes)
        return np.stack([np.asarray(c) for c in codes], axis=-1)

    def _codes(self, x):
        """Float -> UInt32 codes, traced (not evaluated): the rule of :func:`encode_srgb8`."""
        from svcore.mi_env import dr

        mi = self._mi
        x = dr.clip(x, 0.0, 1.0)
        b = mi.UInt32(dr.clip(mi.Int32(x * _BUCKETS), 0, _BUCKETS))  # the bucket rule of encode_srgb8
        c = dr.gather(mi.UInt32, self._codes_lut, b)
        c += mi.UInt32(x >= dr.gather(mi.Float, self._thr, c))
        return c


def decode_srgb8(codes: np.ndarray) -> np.ndarray:
    """uint8 sRGB codes -> linear float32 in [0, 1]."""
    return decode_lut()[np.asarray(codes, np.uint8)]


def encode_srgb8_reference(linear: np.ndarray) -> np.ndarray:
    """The slow, direct definition (colour-science per call), for tests."""
    return np.round(255.0 * srgb_encode(np.clip(linear, 0, 1)).astype(np.float64)).astype(np.uint8)
