"""The SVBRDF map set of DESIGN.md, in memory: float32, linear, [0, 1], layout (H, W, C)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from svcore.errors import SvgenError

#: channels per map, in the canonical order used by stores and the network.
MAP_CHANNELS: dict[str, int] = {"normal": 3, "diffuse": 3, "specular": 3, "roughness": 1}
MAP_NAMES: tuple[str, ...] = tuple(MAP_CHANNELS)


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
        if np.abs(np.linalg.norm(n, axis=-1) - 1).max() > normal_tol:
            raise InvalidMaps("normal map has vectors that are not unit length")
        if (n[..., 2] <= 0).any():
            raise InvalidMaps("normal map has normals with z <= 0")
        return self


def normalize(v: np.ndarray, eps: float = 1e-8) -> np.ndarray:
    """Normalise vectors along the last axis (float32)."""
    v = np.asarray(v, dtype=np.float32)
    return (v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), eps)).astype(np.float32)


def encode_normal(n: np.ndarray) -> np.ndarray:
    """Tangent-space normal -> [0, 1] encoding (n + 1) / 2."""
    return (np.asarray(n, np.float32) + 1.0) * 0.5


def decode_normal(e: np.ndarray) -> np.ndarray:
    """[0, 1] encoding -> unit normal (renormalised, z clamped positive)."""
    n = np.asarray(e, np.float32) * 2.0 - 1.0
    n[..., 2] = np.maximum(n[..., 2], 1e-4)
    return normalize(n)
