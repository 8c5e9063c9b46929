"""Image files at the edges of the project: PNG/JPEG (sRGB, 8/16-bit) and EXR (linear float), one place.

Transfer functions come from colour-science (the sRGB IEC 61966-2-1 curve), never a bare gamma 2.2:
the original code's users were repeatedly confused about which images were gamma-encoded.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import SvgenError


class ImageError(SvgenError):
    """An image that cannot be read or has the wrong shape."""


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """Linear [0,1] -> sRGB-encoded [0,1] (float32)."""
    import colour

    return np.asarray(colour.cctf_encoding(np.clip(linear, 0, 1), function="sRGB"), np.float32)


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """sRGB-encoded [0,1] -> linear [0,1] (float32)."""
    import colour

    return np.asarray(colour.cctf_decoding(np.clip(encoded, 0, 1), function="sRGB"), np.float32)


def write_png(path: str | Path, img: np.ndarray) -> Path:
    """Write (H, W, 3) or (H, W) values in [0, 1] as an 8-bit PNG (values written as given, no encoding)."""
    from PIL import Image

    path = Path(path)
    a = np.clip(np.asarray(img, np.float64), 0, 1)
    if a.ndim == 3 and a.shape[-1] == 1:
        a = a[..., 0]
    Image.fromarray(np.round(a * 255).astype(np.uint8)).save(path)
    return path


def write_png16(path: str | Path, img: np.ndarray) -> Path:
    """Write (H, W, C) or (H, W) values in [0, 1] as a 16-bit PNG (grey, grey+alpha, RGB or RGBA; values written
    as given, no encoding). pypng, since Pillow cannot write 16-bit colour PNGs."""
    import png

    path = Path(path)
    a = np.round(np.clip(np.asarray(img, np.float64), 0, 1) * 65535).astype(np.uint16)
    if a.ndim == 2:
        a = a[..., None]
    h, w, c = a.shape
    with open(path, "wb") as f:
        png.Writer(w, h, greyscale=c in (1, 2), alpha=c in (2, 4), bitdepth=16).write(f, a.reshape(h, w * c).tolist())
    return path


def read_ldr(path: str | Path) -> np.ndarray:
    """Read a PNG/JPEG as (H, W, 3) float32 in [0, 1], still encoded as stored (no transfer function applied).

    Raises:
        ImageError: unreadable file or not an RGB/grey image.
    """
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            bits = 16 if im.mode in ("I;16", "I;16B", "I") else 8
            a = np.asarray(im.convert("RGB") if bits == 8 else im, np.float32)
    except (OSError, UnidentifiedImageError) as e:
        raise ImageError(f"cannot read image {path}: {e}") from None
    a = a / (65535.0 if bits == 16 else 255.0)
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=-1)
    return a.astype(np.float32)


def write_exr(path: str | Path, img: np.ndarray) -> Path:
    """Write (H, W, 3) float values as a linear float32 EXR (ZIP compressed)."""
    import OpenEXR

    a = np.ascontiguousarray(np.asarray(img, np.float32))
    if a.ndim == 2:
        a = a[..., None]
    if a.shape[-1] == 1:
        a = np.repeat(a, 3, axis=-1)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": a}) as f:
        f.write(str(path))
    return Path(path)


def read_exr(path: str | Path) -> np.ndarray:
    """Read an EXR's RGB (or R,G,B, or Y) channels as (H, W, 3) float32, linear.

    Raises:
        ImageError: unreadable file or no colour channels.
    """
    import OpenEXR

    try:
        with OpenEXR.File(str(path)) as f:
            ch = f.channels()
            if "RGB" in ch:
                a = ch["RGB"].pixels
            elif all(c in ch for c in "RGB"):
                a = np.stack([ch[c].pixels for c in "RGB"], axis=-1)
            elif "Y" in ch:
                a = np.repeat(ch["Y"].pixels[..., None], 3, axis=-1)
            else:
                raise ImageError(f"{path} has no RGB or Y channels (has {', '.join(ch)})")
    except ImageError:
        raise
    except Exception as e:
        raise ImageError(f"cannot read EXR {path}: {e}") from None
    a = np.asarray(a, np.float32)
    if a.ndim != 3 or a.shape[-1] != 3:
        raise ImageError(f"{path}: expected an RGB image, got shape {a.shape}")
    return a
