"""sRGB <-> linear transfer functions (colour-science's curve, :mod:`svcore.srgb`), applied once at the edges.

Artist colour parameters are sRGB-encoded; materials decode them once per
generation with :func:`srgb_to_linear`. Previews encode linear maps once with
:func:`linear_to_srgb`.
"""
from __future__ import annotations

import numpy as np

from svcore import srgb


def srgb_to_linear(rgb) -> np.ndarray:
    """Decode sRGB values in [0, 1] (any shape, e.g. (3,)) to linear float32 (IEC 61966-2-1 EOTF)."""
    x = np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0)
    return srgb.decode(x).astype(np.float32)


def linear_to_srgb(x) -> np.ndarray:
    """Encode linear values in [0, 1] (any shape, e.g. (H, W, 3)) to sRGB float32 for display."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return srgb.encode(x).astype(np.float32)


def color_param(params: dict, prefix: str) -> np.ndarray:
    """The linear RGB (3,) float32 colour of sRGB parameters ``<prefix>_r``, ``_g``, ``_b``."""
    return srgb_to_linear([params[f"{prefix}_r"], params[f"{prefix}_g"], params[f"{prefix}_b"]])
