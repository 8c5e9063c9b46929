"""Perturbation of imported materials: a small generic parameter table applied to stored maps, so `svgen sample
--from IMPORTED` gives imported materials what presets get from their own tables.

Every parameter's default is the identity (variant 0 is the imported material itself); variant k >= 1 draws the
table exactly as presets are drawn (pipeline.sample.perturb: truncated normal around the default, width
sigma * (high - low), seed derive_seed(master, "sample", crc32(material name), k)).

Order of application: texture transform (quarter turns, then periodic zoom) -> colour -> roughness -> specular
-> normal strength. Quarter turns and a periodic zoom keep the maps tileable; an arbitrary rotation would not.
"""
from __future__ import annotations

import numpy as np

from materials.capture import NORMAL_Z_MIN
from materials.maps import SVBRDF, normalize
from materials.params import Param, ParamTable

TABLE = ParamTable((
    Param("hue_shift", 0.0, -0.08, 0.08, "rotation of diffuse and specular colour about the grey axis, in turns"),
    Param("albedo_scale", 1.0, 0.6, 1.4, "diffuse albedo multiplier"),
    Param("roughness_scale", 1.0, 0.6, 1.4, "roughness multiplier (after the gamma)"),
    Param("roughness_gamma", 1.0, 0.6, 1.6, "roughness exponent: r -> r^gamma"),
    Param("specular_scale", 1.0, 0.5, 2.0, "specular F0 multiplier"),
    Param("normal_strength", 1.0, 0.3, 2.0, "multiplier of the normals' slopes (n_x/n_z, n_y/n_z)"),
    Param("texture_scale", 1.0, 1.0, 2.0, "tiles of the material across the map (periodic, bilinear)"),
    Param("rotation", 0.0, 0.0, 3.0, "quarter turns counter-clockwise", kind="int"),
))


class ImportedPreset:
    """Duck-types what pipeline.sample.perturb reads of a preset (its exposed table)."""

    exposed = TABLE


def _hue(rgb: np.ndarray, turns: float) -> np.ndarray:
    """Rotate colours about the grey axis (1, 1, 1) by ``turns`` of a full turn (Rodrigues; greys are fixed)."""
    if turns == 0:
        return rgb
    a = 2 * np.pi * turns
    k = np.ones(3) / np.sqrt(3)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    r = np.eye(3) + np.sin(a) * kx + (1 - np.cos(a)) * kx @ kx
    return (rgb @ r.T).astype(np.float32)


def _zoom(a: np.ndarray, s: float) -> np.ndarray:
    """Periodic bilinear resampling showing ``s`` tiles across the map (s = 1: the identity)."""
    if s == 1.0:
        return a
    from scipy.ndimage import map_coordinates

    n = a.shape[0]
    c = (np.arange(n) + 0.5) * s - 0.5
    rows, cols = np.meshgrid(c, c, indexing="ij")
    return np.stack([map_coordinates(a[..., ch], [rows, cols], order=1, mode="grid-wrap") for ch in range(a.shape[2])],
                    axis=-1).astype(np.float32)


def apply(m: SVBRDF, p: dict[str, float]) -> SVBRDF:
    """The perturbed material (maps (S, S, C) float32); ``p`` holds every TABLE parameter."""
    k = int(p["rotation"]) % 4
    maps = {n: np.rot90(getattr(m, n), k, axes=(0, 1)) for n in ("normal", "diffuse", "specular", "roughness")}
    n = maps["normal"].copy()
    for _ in range(k):  # the surface turns with the texture: (x, y) -> (-y, x) per counter-clockwise quarter turn
        n[..., 0], n[..., 1] = -n[..., 1].copy(), n[..., 0].copy()
    maps = {name: _zoom(np.ascontiguousarray(a), p["texture_scale"]) for name, a in {**maps, "normal": n}.items()}
    diffuse = np.clip(_hue(maps["diffuse"], p["hue_shift"]) * p["albedo_scale"], 0, 1)
    specular = np.clip(_hue(maps["specular"], p["hue_shift"]) * p["specular_scale"], 0, 1)
    rough = np.clip(p["roughness_scale"] * np.clip(maps["roughness"], 0, 1) ** p["roughness_gamma"], 0, 1)
    n = maps["normal"]
    nz = np.maximum(n[..., 2:3], NORMAL_Z_MIN)
    normal = normalize(np.concatenate([n[..., :2] / nz * p["normal_strength"], np.ones_like(nz)], -1))
    return SVBRDF(normal=normal, diffuse=diffuse.astype(np.float32), specular=specular.astype(np.float32),
                  roughness=rough.astype(np.float32))
