"""Writers of the fixture material folders the import tests build themselves (no downloads)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from svcore.image_io import write_png, write_png16


def png8(path: Path, a: np.ndarray) -> Path:
    """Values in [0, 1], (H, W) or (H, W, C) -> 8-bit PNG."""
    return write_png(path, a)


def png16(path: Path, a: np.ndarray) -> Path:
    """Values in [0, 1] -> 16-bit PNG (grey or RGB)."""
    return write_png16(path, a)


def exr(path: Path, a: np.ndarray, channels: str = "RGB") -> Path:
    import OpenEXR

    a = np.asarray(a, np.float32)
    if a.ndim == 2:
        a = a[..., None]
    chans = {c: np.ascontiguousarray(a[..., i]) for i, c in enumerate(channels)}
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, chans) as f:
        f.write(str(path))
    return path


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def bumpy_normals(s: int, rng) -> np.ndarray:
    """(s, s, 3) smooth unit normals with varied x and y slopes (OpenGL convention); ``rng`` draws the two waves'
    phases, so materials made with different draws differ (white noise would break the smoothness tests rely on)."""
    u = (np.arange(s) + 0.5) / s
    x, y = np.meshgrid(u, 1 - u)
    px, py = rng.uniform(0, 2 * np.pi, 2)
    sx = 0.4 * np.sin(2 * np.pi * (x + 0.3 * y) + px)
    sy = 0.5 * np.cos(2 * np.pi * (2 * y - x) + py)
    return unit(np.stack([-sx, -sy, np.ones_like(sx)], -1)).astype(np.float32)


def height_field(s: int) -> tuple[np.ndarray, callable]:
    """Height h = 0.5 + 0.25 sin(2 pi u) cos(2 pi v) at pixel centres (u right, v up) and its analytic gradient."""
    c = (np.arange(s) + 0.5) / s
    u, v = np.meshgrid(c, 1 - c)
    h = 0.5 + 0.25 * np.sin(2 * np.pi * u) * np.cos(2 * np.pi * v)

    def grad(uu, vv):
        return (0.25 * 2 * np.pi * np.cos(2 * np.pi * uu) * np.cos(2 * np.pi * vv),
                -0.25 * 2 * np.pi * np.sin(2 * np.pi * uu) * np.sin(2 * np.pi * vv))

    return h, grad


def ambientcg(root: Path, name: str, s: int, rng, normals: dict[str, np.ndarray]) -> Path:
    """An ambientCG-style folder: <name>_2K-PNG_Color/Roughness/NormalGL|NormalDX/AmbientOcclusion.png."""
    d = root / name
    d.mkdir(parents=True)
    stem = f"{name}_2K-PNG"
    png8(d / f"{stem}_Color.png", rng.random((s, s, 3)))
    png8(d / f"{stem}_Roughness.png", rng.random((s, s)))
    png8(d / f"{stem}_AmbientOcclusion.png", rng.random((s, s)))
    for conv, n in normals.items():
        png8(d / f"{stem}_Normal{conv}.png", (n + 1) / 2)
    return d


def matsynth(root: Path, name: str, s: int, base: np.ndarray, metal: np.ndarray, height: np.ndarray,
             meta: dict | None = None) -> Path:
    """A MatSynth-style folder: basecolor.png (16-bit), metallic.png, roughness.png, height.png (16-bit),
    metadata.json."""
    d = root / name
    d.mkdir(parents=True)
    png16(d / "basecolor.png", base)
    png8(d / "metallic.png", metal)
    png8(d / "roughness.png", np.full((s, s), 0.5))
    png16(d / "height.png", height)
    (d / "metadata.json").write_text(json.dumps(meta or {"category": "metal", "license": "CC0"}))
    return d
