"""The SVBRDF map set of DESIGN.md, in memory: float32, linear, [0, 1], layout (H, W, C)."""
from __future__ import annotations

from dataclasses import dataclass
from itertools import accumulate

import numpy as np

from svcore.errors import SvgenError

from .capture import NORMAL_Z_MIN

#: channels per map, in the canonical order used by stores and the network.
MAP_CHANNELS: dict[str, int] = {"normal": 3, "diffuse": 3, "specular": 3, "roughness": 1}
MAP_NAMES: tuple[str, ...] = tuple(MAP_CHANNELS)

# The packed layout: the four maps' channels stacked on one axis in MAP_NAMES order, 10 channels. numpy holds
# it as (..., H, W, 10) (:func:`pack_maps`), torch as (B, 10, H, W), the Mitsuba plugin as 10 flat planes; all
# index it with MAP_SLICES.
#: slice of each map in the packed channel axis: normal 0:3, diffuse 3:6, specular 6:9, roughness 9:10.
MAP_SLICES: dict[str, slice] = {k: slice(end - c, end) for (k, c), end in
                                 zip(MAP_CHANNELS.items(), accumulate(MAP_CHANNELS.values()))}
#: channels of the packed layout.
N_CHANNELS: int = sum(MAP_CHANNELS.values())
#: short names of the packed channels, in order (the plugin's texture planes are ``tex_<name>``).
CHANNEL_NAMES: tuple[str, ...] = ("nx", "ny", "nz", "dr", "dg", "db", "sr", "sg", "sb", "rough")


class InvalidMaps(SvgenError, ValueError):
    """Maps that break the conventions (shape, range, finiteness, unit normals)."""


@dataclass
class SVBRDF:
    """One spatially varying BRDF.

    Attributes:
        normal: (H, W, 3) unit tangent-space normals, z > 0; x right, y up in the image.
        diffuse: (H, W, 3) linear RGB albedo in [0, 1].
        specular: (H, W, 3) linear RGB F0 in [0, 1].
        roughness: (H, W, 1) perceptual roughness r in [0, 1] (alpha = r**2).
    """

    normal: np.ndarray
    diffuse: np.ndarray
    specular: np.ndarray
    roughness: np.ndarray

    @property
    def size(self) -> int:
        return int(self.normal.shape[0])

    def as_dict(self) -> dict[str, np.ndarray]:
        return {k: getattr(self, k) for k in MAP_NAMES}

    @classmethod
    def from_dict(cls, d: dict[str, np.ndarray]) -> "SVBRDF":
        return cls(**{k: np.asarray(d[k], dtype=np.float32) for k in MAP_NAMES})

    def validate(self, normal_tol: float = 1e-3) -> "SVBRDF":
        """Raise :class:`InvalidMaps` unless the maps follow DESIGN.md. Returns self."""
        h = w = None
        for name, c in MAP_CHANNELS.items():
            a = getattr(self, name)
            if a.ndim != 3 or a.shape[2] != c:
                raise InvalidMaps(f"{name} map has shape {a.shape}, expected (H, W, {c})")
            if h is None:
                h, w = a.shape[:2]
            elif a.shape[:2] != (h, w):
                raise InvalidMaps(f"{name} map is {a.shape[:2]}, other maps are {(h, w)}")
            if not np.all(np.isfinite(a)):
                raise InvalidMaps(f"{name} map has non-finite values")
            if name != "normal" and (a.min() < 0 or a.max() > 1):
                raise InvalidMaps(f"{name} map leaves [0, 1]: [{a.min():.4g}, {a.max():.4g}]")
        n = self.normal
        if np.abs(vector_length(n) - 1).max() > normal_tol:
            raise InvalidMaps("normal map has vectors that are not unit length")
        if (n[..., 2] <= 0).any():
            raise InvalidMaps("normal map has normals with z <= 0")
        return self


def vector_length(v: np.ndarray) -> np.ndarray:
    """Lengths of 3-vectors along the last axis: (..., 3) -> (...), in v's float type.

    Three products and two sums by hand: ``np.linalg.norm(v, axis=-1)`` gives the same float32 values, 4x slower
    on maps (a generic reduction over an axis of length 3), and every map read and blend normalises normals.
    """
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return np.sqrt(x * x + y * y + z * z)


def normalize(v: np.ndarray, eps: float = 1e-8) -> np.ndarray:
    """Normalise 3-vectors along the last axis (float32).

    One channel at a time: broadcasting (..., 3) / (..., 1) runs numpy's inner loop over the axis of length 3,
    3x slower on maps than three long strided divisions of the same values.
    """
    v = np.asarray(v, dtype=np.float32)
    inv = np.maximum(vector_length(v), np.float32(eps))
    out = np.empty_like(v)
    for c in range(v.shape[-1]):
        np.divide(v[..., c], inv, out=out[..., c])
    return out


def encode_normal(n: np.ndarray) -> np.ndarray:
    """Tangent-space normal -> [0, 1] encoding (n + 1) / 2."""
    return (np.asarray(n, np.float32) + 1.0) * 0.5


def decode_normal(e: np.ndarray) -> np.ndarray:
    """[0, 1] encoding -> unit normal (renormalised, z clamped positive)."""
    n = np.asarray(e, np.float32) * 2.0 - 1.0
    n[..., 2] = np.maximum(n[..., 2], NORMAL_Z_MIN)
    return normalize(n)


def pack_maps(m: SVBRDF) -> np.ndarray:
    """The packed layout of maps (see :data:`MAP_SLICES`).

    Args:
        m: maps of shape (..., H, W, C) each (any leading axes, broadcast arrays allowed).

    Returns:
        (..., H, W, 10) float32, a new array.
    """
    return np.concatenate([getattr(m, k) for k in MAP_NAMES], -1).astype(np.float32)


def unpack_maps(a: np.ndarray) -> SVBRDF:
    """The inverse of :func:`pack_maps`: (..., H, W, 10) -> SVBRDF of contiguous float32 copies."""
    a = np.asarray(a)
    if a.shape[-1] != N_CHANNELS:
        raise InvalidMaps(f"packed maps have {a.shape[-1]} channels, expected {N_CHANNELS}")
    return SVBRDF(**{k: np.array(a[..., sl], np.float32, order="C") for k, sl in MAP_SLICES.items()})
