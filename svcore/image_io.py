"""Image files at the edges of the project: PNG/JPEG (sRGB, 8/16-bit) and EXR (linear float), one place.

Transfer functions are colour-science's sRGB IEC 61966-2-1 curve (computed by :mod:`svcore.srgb`, bit for bit
colour-science's, without its 2-second import), never a bare gamma 2.2: the original code's users were repeatedly
confused about which images were gamma-encoded.

Photos are read as the camera meant them (:func:`read_ldr`): turned upright by their EXIF orientation, 16-bit PNGs
at 16 bits, and pixels in an embedded ICC profile's space converted to sRGB (LittleCMS through Pillow's ImageCms).
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from . import srgb
from .errors import SvgenError
from .log import get_logger

log = get_logger(__name__)

#: EXIF tag of the orientation
ORIENTATION_TAG = 0x0112
#: EXIF orientation -> the numpy operation on (H, W, ...) that makes the image upright; the same as
#: ``PIL.ImageOps.exif_transpose`` (tests/test_image_io.py compares them), for arrays Pillow cannot hold (16-bit RGB)
UPRIGHT = {
    1: lambda a: a,
    2: lambda a: a[:, ::-1],                    # mirrored left-right
    3: lambda a: a[::-1, ::-1],                 # rotated 180
    4: lambda a: a[::-1],                       # mirrored top-bottom
    5: lambda a: a.swapaxes(0, 1),              # transposed
    6: lambda a: np.rot90(a, -1),               # rotated 90 clockwise to be upright
    7: lambda a: a[::-1, ::-1].swapaxes(0, 1),  # transversed
    8: lambda a: np.rot90(a, 1),                # rotated 90 counter-clockwise to be upright
}


class ImageError(SvgenError):
    """An image that cannot be read or has the wrong shape."""


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """Linear [0,1] -> sRGB-encoded [0,1] (float32)."""
    return srgb.encode(np.clip(linear, 0, 1)).astype(np.float32)


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """sRGB-encoded [0,1] -> linear [0,1] (float32)."""
    return srgb.decode(np.clip(encoded, 0, 1)).astype(np.float32)


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
    as given, no encoding): :func:`png_bytes`, since Pillow cannot write 16-bit colour PNGs."""
    path = Path(path)
    path.write_bytes(png_bytes(np.round(np.clip(np.asarray(img, np.float64), 0, 1) * 65535).astype(np.uint16)))
    return path


#: PNG colour type of 1 to 4 channels: grey, grey + alpha, RGB, RGBA
_PNG_COLOUR = {1: 0, 2: 4, 3: 2, 4: 6}


def png_bytes(codes: np.ndarray, level: int = 6) -> bytes:
    """A PNG file of (H, W) or (H, W, C) uint8 or uint16 codes (C = 1 grey, 2 grey + alpha, 3 RGB, 4 RGBA), written
    as given. numpy and zlib (pypng's pure-Python writer took 0.3 s for one 256^2 16-bit RGB map; this ~100 times
    less): every row 'Sub'-filtered (PNG filter type 1, the byte bpp places left subtracted), one IDAT chunk, zlib
    ``level``: the bytes are a function of the codes and the zlib version."""
    import struct
    import zlib

    a = np.asarray(codes)
    if a.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"png_bytes takes uint8 or uint16 codes, got {a.dtype}")
    if a.ndim == 2:
        a = a[..., None]
    h, w, c = a.shape
    raw = np.ascontiguousarray(a.astype(">u2") if a.dtype == np.uint16 else a).view(np.uint8).reshape(h, -1)
    bpp = c * a.dtype.itemsize
    rows = np.empty((h, raw.shape[1] + 1), np.uint8)
    rows[:, 0] = 1  # filter type Sub
    rows[:, 1:1 + bpp] = raw[:, :bpp]
    rows[:, 1 + bpp:] = raw[:, bpp:] - raw[:, :-bpp]  # modulo 256

    def chunk(tag: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body))

    header = struct.pack(">IIBBBBB", w, h, a.dtype.itemsize * 8, _PNG_COLOUR[c], 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows.tobytes(), level))
            + chunk(b"IEND", b""))


def _is_16bit(im) -> bool:
    """Whether a Pillow image holds 16 bits per sample (Pillow opens 16-bit RGB PNGs as 8-bit "RGB")."""
    if im.mode.startswith("I;16") or im.mode == "I":
        return True
    raw = im.tile[0][3] if im.tile else ""
    raw = raw[0] if isinstance(raw, tuple) else raw
    return isinstance(raw, str) and raw.endswith(("16", "16B", "16L"))


def _read_png16(path: Path) -> np.ndarray:
    """A 16-bit PNG through pypng as (H, W, C) uint16 (Pillow would reduce 16-bit colour to 8 bits)."""
    import png

    w, h, rows, meta = png.Reader(filename=str(path)).asDirect()
    return np.vstack([np.asarray(r, np.uint16) for r in rows]).reshape(h, w, meta["planes"])


def _is_srgb(profile) -> bool:
    """An sRGB profile (by its description: "sRGB IEC61966-2.1", "sRGB built-in"): the values are already sRGB."""
    from PIL import ImageCms

    return "srgb" in ImageCms.getProfileDescription(profile).lower().replace(" ", "")


def _to_srgb(im, icc: bytes, path) -> object:
    """``im`` converted from its embedded ICC profile to sRGB (an sRGB profile: unchanged); warns and keeps the
    stored values when LittleCMS cannot convert it."""
    from PIL import ImageCms

    try:
        src = ImageCms.ImageCmsProfile(io.BytesIO(icc))
        if _is_srgb(src):
            return im
        return ImageCms.profileToProfile(im, src, ImageCms.createProfile("sRGB"), outputMode="RGB",
                                         renderingIntent=ImageCms.Intent.RELATIVE_COLORIMETRIC)
    except (ImageCms.PyCMSError, OSError, ValueError) as e:
        log.warning("%s: its ICC colour profile cannot be converted to sRGB (%s); values read as sRGB", path,
                    " ".join(str(e).split()))
        return im


def _srgb_bytes(icc: bytes) -> bool:
    from PIL import ImageCms

    try:
        return _is_srgb(ImageCms.ImageCmsProfile(io.BytesIO(icc)))
    except (ImageCms.PyCMSError, OSError, ValueError):
        return False


def read_ldr(path: str | Path) -> np.ndarray:
    """Read a PNG/JPEG as (H, W, 3) float32 in [0, 1], still encoded as stored (no transfer function applied).

    The image is turned upright by its EXIF orientation; a 16-bit PNG keeps its 16 bits; pixels in another colour
    space than sRGB (an embedded ICC profile: Display P3, Adobe RGB, a camera's) are converted to sRGB, or, for
    16-bit images and profiles LittleCMS cannot use, left as stored with a one-line warning.

    Raises:
        ImageError: unreadable file or not an RGB/grey image.
    """
    from PIL import Image, ImageOps, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            icc = im.info.get("icc_profile")
            if im.format == "PNG" and _is_16bit(im):
                orientation = im.getexif().get(ORIENTATION_TAG, 1)
                a = _read_png16(Path(path)).astype(np.float32) / 65535.0
                a = UPRIGHT.get(orientation, UPRIGHT[1])(a)
                if icc and not _srgb_bytes(icc):
                    log.warning("%s: a 16-bit image with an ICC colour profile: the profile is not applied (values "
                                "read as sRGB); save it as 8-bit sRGB or 16-bit sRGB to silence this", path)
            else:
                im = ImageOps.exif_transpose(im)
                if icc:  # LittleCMS converts colour or grey pixels: palette and alpha dropped first
                    im = im.convert({"LA": "L", "La": "L"}.get(im.mode, "RGB")) if im.mode not in (
                        "RGB", "L", "CMYK") else im
                    im = _to_srgb(im, icc, path)
                a = np.asarray(im.convert("RGB"), np.float32) / 255.0
    except (OSError, UnidentifiedImageError, SyntaxError) as e:
        raise ImageError(f"cannot read image {path}: {' '.join(str(e).split())}") from None
    if a.ndim == 2:
        a = a[..., None]
    if a.shape[-1] in (2, 4):  # drop alpha
        a = a[..., :-1]
    if a.shape[-1] == 1:
        a = np.repeat(a, 3, axis=-1)
    return np.ascontiguousarray(a, dtype=np.float32)


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


def read_exr_channels(path: str | Path) -> np.ndarray:
    """The one EXR reader of the project: an EXR's colour channels as (H, W, C) float32, linear, as stored.

    C is 3 for R,G,B (RGB, RGBA: the alpha channel is dropped, with a warning when it is not opaque, since the
    colours of a transparent EXR are often premultiplied by it), 2 for R,G only (a two-channel normal map), 1 for
    a single Y, R, G or B channel. Channels are read one by one, so any of these layouts and pixel types work.

    Raises:
        ImageError: unreadable file, or no R, G, B or Y channel.
    """
    import OpenEXR

    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            ch = {k: np.asarray(v.pixels, np.float32) for k, v in f.channels().items()}
    except Exception as e:
        raise ImageError(f"cannot read EXR {path}: {' '.join(str(e).split())}") from None
    if all(c in ch for c in "RGB"):
        if "A" in ch and not np.all(ch["A"] == 1):
            log.warning("%s: its alpha channel is not opaque everywhere; alpha is dropped and the colours read as "
                        "stored", path)
        return np.stack([ch[c] for c in "RGB"], axis=-1)
    if "R" in ch and "G" in ch:
        return np.stack([ch["R"], ch["G"]], axis=-1)
    for c in ("Y", "R", "G", "B"):
        if c in ch:
            return ch[c][..., None]
    raise ImageError(f"{path} has no R, G, B or Y channels (has {', '.join(sorted(ch))})")


def read_exr(path: str | Path) -> np.ndarray:
    """Read an EXR photo (RGB, RGBA with alpha dropped, or grey Y) as (H, W, 3) float32, linear
    (:func:`read_exr_channels`).

    Raises:
        ImageError: unreadable file or no colour channels.
    """
    a = read_exr_channels(path)
    if a.shape[-1] == 1:
        return np.repeat(a, 3, axis=-1)
    if a.shape[-1] != 3:
        raise ImageError(f"{path}: expected an RGB, RGBA or grey image, got channels R and G only")
    return a
