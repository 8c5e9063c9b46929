"""The 2018 dataset layout (Deschaintre et al. 2018; `svgen export --format deschaintre` writes it): one PNG per
sample, 5 square tiles side by side, ``input | normal | diffuse | roughness | specular``. The maps are linear as
stored (no transfer function), normals encoded (n + 1) / 2, roughness grey (repeated over RGB). The input photo
was read as linear by the 2018 code; ``input_space="srgb"`` decodes it with colour-science instead.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from materials.maps import SVBRDF

from svcore.image_io import srgb_decode

from . import ImportInputError
from .discover import MaterialSource, unique, walk
from .normals import decode, finish
from .readers import info, read
from .resample import resize

TILES = ("input", "normal", "diffuse", "roughness", "specular")
INPUT_SPACES = ("linear", "srgb")


def find_strips(sources: list[Path]) -> list[MaterialSource]:
    """Every .png strip under the sources (files or folders), sorted by name; names are the file stems.

    Raises:
        ImportInputError: a missing or empty source, one without PNG files, duplicate stems, a symlink loop.
    """
    mats = []
    for src in sources:
        if not src.exists():
            raise ImportInputError(f"source {src} does not exist")
        files = [src] if src.is_file() else [d / n for d, names in walk(src) for n in names]
        if not files:
            raise ImportInputError(f"source {src} is empty")
        pngs = [f for f in files if f.suffix.lower() == ".png"]
        if not pngs:
            raise ImportInputError(f"no .png strips under {src} (the deschaintre layout is one PNG per sample)")
        mats += [MaterialSource(name=f.stem, root=f, layout="deschaintre", files={"strip": f}) for f in pngs]
    return unique(mats)


def tile_size(mat: MaterialSource) -> int:
    """Side of the strip's tiles, checked from the header.

    Raises:
        ImportInputError: width not 5 tiles, or tiles that are not square.
    """
    i = info(mat.root)
    if i.width % 5:
        raise ImportInputError(f"{mat.root}: width {i.width} is not 5 tiles (input|normal|diffuse|roughness|specular)")
    if i.width // 5 != i.height:
        raise ImportInputError(f"{mat.root}: tiles are {i.width // 5}x{i.height}, not square")
    return i.height


def split(mat: MaterialSource, size: int, input_space: str) -> tuple[np.ndarray, SVBRDF, dict]:
    """Read one strip.

    Returns:
        input image (size, size, 3) float32 linear; maps; record (tile size, spaces).
    """
    t = tile_size(mat)
    a = read(mat.root)
    if a.shape[-1] < 3:
        a = np.repeat(a[..., :1], 3, axis=-1)
    tiles = {k: a[:, i * t:(i + 1) * t, :3] for i, k in enumerate(TILES)}
    image = tiles["input"]
    if input_space == "srgb":
        image = srgb_decode(image)
    image = resize(np.ascontiguousarray(image), size)
    normal = finish(resize(decode(tiles["normal"], mat.root), size), directx=False)
    maps = SVBRDF(normal=normal, diffuse=resize(np.ascontiguousarray(tiles["diffuse"]), size),
                  specular=resize(np.ascontiguousarray(tiles["specular"]), size),
                  roughness=resize(np.ascontiguousarray(tiles["roughness"].mean(-1, keepdims=True)), size))
    rec = {"tile_size": t, "input_space": input_space, "maps": {
        "input": {"space": "linear as stored" if input_space == "linear" else "sRGB -> linear (colour-science)"},
        "normal": {"space": "data: (n+1)/2"}, "diffuse": {"space": "linear as stored"},
        "roughness": {"space": "data, grey"}, "specular": {"space": "linear as stored"}},
        "normal": {"convention": "opengl", "decided_by": "2018 layout"}, "warnings": []}
    return np.clip(image, 0, 1).astype(np.float32), maps.validate(normal_tol=1e-3), rec
