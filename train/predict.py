"""``svtrain predict PHOTO``: maps from one flash photo.

PNG/JPEG are sRGB-encoded and linearised with colour-science; EXR is read as linear (values above 1
are clipped: the network was trained on LDR renders). The photo is centre-cropped to a square and
resized to the network's training size. Outputs in ``out_dir``: ``{normal,diffuse,roughness,specular}.png``
(normal encoded (n+1)/2, the others sRGB-encoded for viewing), the same maps as linear ``.exr``
(normal as the raw unit vector), ``input.png`` (what the network saw) and ``rerender.png`` (the maps
under a moved flash).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from torch.nn import functional as F

from svcore.image_io import ImageError, read_exr, read_ldr, srgb_decode, srgb_encode, write_exr, write_png

from .brdf import DIFFUSE, NORMAL, ROUGHNESS, SPECULAR
from .checkpoint import load_model
from .render import flash_render

MIN_SIDE = 32
LDR_SUFFIXES = (".png", ".jpg", ".jpeg")
#: light offset of the re-rendering written beside the maps (the capture flash sits near the centre).
MOVED_LIGHT = (0.6, 0.4)


def read_photo(path: str | Path) -> np.ndarray:
    """A photo as (H, W, 3) float32 linear in [0, 1].

    Raises:
        ImageError: missing/unreadable file, unknown format, too small, non-finite values.
    """
    p = Path(path)
    if not p.is_file():
        raise ImageError(f"photo {str(p)!r} does not exist")
    suffix = p.suffix.lower()
    if suffix in LDR_SUFFIXES:
        img = srgb_decode(read_ldr(p))
    elif suffix == ".exr":
        img = read_exr(p)
        if not np.all(np.isfinite(img)):
            raise ImageError(f"{p} has non-finite pixels")
        img = np.clip(img, 0.0, 1.0)
    else:
        raise ImageError(f"{p}: unsupported format {suffix or '(none)'}; use PNG, JPEG or EXR")
    if img.ndim != 3 or img.shape[2] != 3:
        raise ImageError(f"{p}: expected an RGB image, got shape {img.shape}")
    if min(img.shape[:2]) < MIN_SIDE:
        raise ImageError(f"{p} is {img.shape[1]}x{img.shape[0]} pixels; need at least {MIN_SIDE} on each side")
    return img.astype(np.float32)


def to_network_input(img: np.ndarray, size: int) -> torch.Tensor:
    """Centre-crop to a square and resize (area-averaging when shrinking). Returns (1, 3, size, size)."""
    h, w = img.shape[:2]
    s = min(h, w)
    y0, x0 = (h - s) // 2, (w - s) // 2
    t = torch.from_numpy(np.ascontiguousarray(img[y0:y0 + s, x0:x0 + s])).permute(2, 0, 1)[None]
    if s != size:
        t = F.interpolate(t, size=(size, size), mode="bilinear", antialias=s > size, align_corners=False)
    return t.clamp(0.0, 1.0)


def _hwc(t: torch.Tensor) -> np.ndarray:
    return t[0].permute(1, 2, 0).numpy()


def write_maps(maps: torch.Tensor, out: Path) -> list[Path]:
    """Write packed maps (1, 10, H, W) as PNG previews and linear EXRs."""
    written = []
    n = _hwc(maps[:, NORMAL])
    written.append(write_png(out / "normal.png", (n + 1.0) * 0.5))
    written.append(write_exr(out / "normal.exr", n))
    for name, sl in (("diffuse", DIFFUSE), ("roughness", ROUGHNESS), ("specular", SPECULAR)):
        a = _hwc(maps[:, sl])
        # Roughness is a perceptual parameter, not a colour: written as is, not sRGB-encoded.
        written.append(write_png(out / f"{name}.png", a if name == "roughness" else srgb_encode(a)))
        written.append(write_exr(out / f"{name}.exr", a))
    return written


@torch.no_grad()
def predict(photo: str | Path, checkpoint_path: str | Path, out_dir: str | Path) -> list[Path]:
    """Run the network on a photo and write maps + re-rendering; returns the written paths."""
    img = read_photo(photo)
    model, cfg = load_model(checkpoint_path)
    x = to_network_input(img, cfg.data.crop)
    maps = model(x)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = write_maps(maps, out)
    written.append(write_png(out / "input.png", srgb_encode(_hwc(x))))
    written.append(write_png(out / "rerender.png", srgb_encode(_hwc(flash_render(maps, torch.tensor(MOVED_LIGHT))))))
    return written


__all__ = ["predict", "read_photo", "to_network_input", "write_maps", "ImageError"]
