"""The sRGB transfer functions (IEC 61966-2-1), computed the way colour-science computes them, without importing it.

colour-science stays the definition: these are its ``eotf_inverse_sRGB`` and ``eotf_sRGB`` (what
``colour.cctf_encoding`` / ``cctf_decoding(function="sRGB")`` call), the same float64 operations in the same order,
and ``tests/test_srgb.py`` holds them bit for bit equal to colour-science on every 8-bit and 16-bit code, a dense
grid and random values, so no stored byte changes. Why not call colour-science here: ``import colour`` costs about
2.2 s of CPU per process (its package import loads ``colour.plotting`` and with it ``matplotlib.pyplot``, pandas and
scipy), and every ``svgen sample``, ``render`` and ``stress`` process and each of their dask workers needs the
curve: that import was a third to a half of each stage's start (``python3 -X importtime``; README "Paper scale").
Colour science beyond this one curve (colour spaces, Lab, chromatic adaptation) still calls colour-science.
"""
from __future__ import annotations

import numpy as np

#: linear value where the curve changes from the linear segment to the power law
LINEAR_KNEE = 0.0031308
#: its encoded value (colour-science's decoding compares against eotf_inverse_sRGB(0.0031308), computed the same way)
ENCODED_KNEE = LINEAR_KNEE * 12.92


def _spow(a: np.ndarray, p: float) -> np.ndarray:
    """colour.algebra.spow: the sign-preserving power sign(a) |a|^p (0 for 0)."""
    return np.sign(a) * np.abs(a) ** p


def encode(linear) -> np.ndarray:
    """Linear values (any shape) -> sRGB-encoded values, float64 (no clipping: negative values keep their sign).

    Args:
        linear: array-like of linear values, normally in [0, 1].

    Returns:
        float64 array of the same shape: ``colour.cctf_encoding(linear, function="sRGB")``.
    """
    lin = np.asarray(linear, np.float64)
    return np.where(lin <= LINEAR_KNEE, lin * 12.92, 1.055 * _spow(lin, 1 / 2.4) - 0.055)


def decode(encoded) -> np.ndarray:
    """sRGB-encoded values (any shape) -> linear values, float64 (no clipping).

    Args:
        encoded: array-like of encoded values, normally in [0, 1].

    Returns:
        float64 array of the same shape: ``colour.cctf_decoding(encoded, function="sRGB")``.
    """
    enc = np.asarray(encoded, np.float64)
    return np.where(ENCODED_KNEE >= enc, enc / 12.92, _spow((enc + 0.055) / 1.055, 2.4))
