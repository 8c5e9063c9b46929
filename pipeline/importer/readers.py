"""Image files -> float arrays with well-kept readers: Pillow (8/16-bit grey PNG, JPEG, 8-bit TIFF), pypng (16-bit
colour PNG, which Pillow reduces to 8 bits), tifffile (TIFF of any depth), OpenEXR (EXR, float).

Values come back as stored: integer images scaled to [0, 1] (no transfer function), EXR as linear floats.

A source is a file path or a :class:`Blob`, an image held in memory (a parquet cell of a `datasets` image column):
the same readers decode both, the blob's format told by its first bytes.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import io
import re

import numpy as np

from . import ImportInputError

#: file signatures -> the extension the readers dispatch on (PNG, JPEG, TIFF little/big-endian and BigTIFF, EXR)
MAGIC = ((b"\x89PNG\r\n\x1a\n", ".png"), (b"\xff\xd8\xff", ".jpg"), (b"II*\x00", ".tif"), (b"MM\x00*", ".tif"),
         (b"II+\x00", ".tif"), (b"MM\x00+", ".tif"), (b"v/1\x01", ".exr"))


@dataclass(frozen=True)
class Blob:
    """An image file's bytes held in memory (one map of a parquet row).

    Attributes:
        name: what messages and records call it (e.g. ``"shard.parquet row 12 basecolor"``).
        data: the encoded file (PNG, JPEG, TIFF ...), as a `datasets` image column's ``bytes`` holds it.
    """

    name: str
    data: bytes = field(repr=False)

    @property
    def suffix(self) -> str:
        """The extension its signature says (".png", ".jpg", ".tif", ".exr"; "" when unknown: Pillow tries)."""
        return next((ext for magic, ext in MAGIC if self.data.startswith(magic)), "")

    def __str__(self) -> str:
        return self.name


def _path(src: str | Path | Blob) -> Path | Blob:
    return src if isinstance(src, Blob) else Path(src)


def _reason(e: Exception) -> str:
    """A reader's error on one line, without object addresses (a message about a blob names its file object,
    ``<_io.BytesIO object at 0x...>``: recorded, it would make the store's bytes differ from run to run)."""
    msg = re.sub(r"<[^<>]* at 0x[0-9a-fA-F]+>", "its bytes", " ".join(str(e).split()))
    return msg or type(e).__name__


def _opened(p: Path | Blob):
    """What Pillow, tifffile and pypng open: the path, or a file object over the blob's bytes."""
    return io.BytesIO(p.data) if isinstance(p, Blob) else p


@dataclass(frozen=True)
class ImageInfo:
    """What a file's header says: size, channels, bits per channel and whether values are linear floats."""

    width: int
    height: int
    channels: int
    bits: int
    float_linear: bool


def _pil_bits(im) -> int:
    if im.mode.startswith("I;16") or im.mode == "I":
        return 16
    raw = im.tile[0][3] if im.tile else ""
    raw = raw[0] if isinstance(raw, tuple) else raw
    return 16 if isinstance(raw, str) and raw.endswith(("16", "16B", "16L")) else 8


def _pil_channels(im) -> int:
    return {"1": 1, "L": 1, "P": 3, "I": 1, "F": 1, "LA": 2, "PA": 4, "RGB": 3, "RGBA": 4, "CMYK": 3, "YCbCr": 3}.get(
        im.mode.split(";")[0], 3)


def info(path: str | Path | Blob) -> ImageInfo:
    """Read only the header of an image.

    Raises:
        ImportInputError: not an image, or unreadable.
    """
    p = _path(path)
    ext = p.suffix.lower()
    try:
        if ext == ".exr":
            _file_only(p)
            import OpenEXR

            with OpenEXR.File(str(p), header_only=True) as f:
                h = f.header()
                (x0, y0), (x1, y1) = h["dataWindow"]
                names = {c.name for c in h["channels"]}
            ch = len(names & set("RGB")) or len(names & {"Y"})
            if "A" in names and ch == 3:
                ch = 3
            return ImageInfo(int(x1 - x0 + 1), int(y1 - y0 + 1), ch, 32, True)
        if ext in (".tif", ".tiff"):
            import tifffile

            with tifffile.TiffFile(_opened(p)) as t:
                page = t.pages[0]
                shape = page.shape
                bits = int(page.bitspersample)
                ch = int(page.samplesperpixel)
                float_ = page.dtype.kind == "f"
            h_, w_ = shape[0], shape[1]
            return ImageInfo(int(w_), int(h_), ch, bits, float_)
        from PIL import Image

        with Image.open(_opened(p)) as im:
            return ImageInfo(im.width, im.height, _pil_channels(im), _pil_bits(im), False)
    except ImportInputError:
        raise
    except Exception as e:
        raise ImportInputError(f"cannot read image {p}: {_reason(e)}") from None


def verify(path: str | Path | Blob) -> ImageInfo:
    """The header of an image, and for PNG the CRC of every chunk (Pillow's ``verify``: a corrupt or truncated
    PNG fails here without decoding its pixels). Other formats: the header only.

    Raises:
        ImportInputError: not an image, unreadable, a PNG with a bad chunk or no end.
    """
    i = info(path)
    p = _path(path)
    if p.suffix.lower() == ".png":
        from PIL import Image

        try:
            with Image.open(_opened(p)) as im:
                im.verify()
        except Exception as e:
            raise ImportInputError(f"cannot read image {p}: {_reason(e)}") from None
    return i


def _file_only(p: Path | Blob) -> None:
    """EXR is read from files only (OpenEXR's reader takes a file name)."""
    if isinstance(p, Blob):
        raise ImportInputError(f"{p}: an EXR image held in memory (a parquet cell) is not read; store such maps as "
                               "16-bit PNG or TIFF")


def read(path: str | Path | Blob) -> np.ndarray:
    """Read an image as (H, W, C) float32: integers scaled to [0, 1] as stored, EXR/float TIFF as is."""
    a = read_raw(path)
    return a if a.dtype == np.float32 else _scale(a)


def read_raw(path: str | Path | Blob, min_size: int | None = None) -> np.ndarray:
    """Read an image as (H, W, C) in its own type: uint8/uint16 codes, or float32 (EXR, float TIFF).

    ``min_size``: JPEG only, let libjpeg decode at a reduced scale (1/2, 1/4, 1/8: DCT-domain averaging, Pillow's
    ``draft``) as long as both sides stay >= ``min_size``; a 2048^2 JPEG read for a 256^2 output decodes ~8x faster.

    Alpha is dropped from RGBA/LA images unless it is the second channel of a 2-channel image (LA), which stays.

    Raises:
        ImportInputError: unreadable, truncated, or with non-finite values.
    """
    p = _path(path)
    ext = p.suffix.lower()
    try:
        if ext == ".exr":
            _file_only(p)
            a = _read_exr(p)
        elif ext in (".tif", ".tiff"):
            import tifffile

            a = tifffile.imread(_opened(p))
            a = a.astype(np.float32) if a.dtype.kind == "f" else a.astype(np.uint16) if a.dtype.itemsize > 1 else \
                a.astype(np.uint8)
        else:
            a = _read_pil(p, min_size)
    except ImportInputError:
        raise
    except Exception as e:
        raise ImportInputError(f"cannot read image {p}: {_reason(e)}") from None
    if a.ndim == 2:
        a = a[..., None]
    if a.shape[-1] == 4:
        a = a[..., :3]
    if a.dtype.kind == "f" and not np.isfinite(a).all():
        raise ImportInputError(f"{p} has NaN or infinite values")
    return np.ascontiguousarray(a)


def _scale(a: np.ndarray) -> np.ndarray:
    if a.dtype.kind == "f":
        return a.astype(np.float32)
    if a.dtype == np.bool_:
        return a.astype(np.float32)
    return a.astype(np.float32) / float(np.iinfo(a.dtype).max)


def _read_pil(p: Path | Blob, min_size: int | None = None) -> np.ndarray:
    from PIL import Image

    with Image.open(_opened(p)) as im:
        if min_size and im.format == "JPEG":
            im.draft(im.mode, (min_size, min_size))
        if p.suffix.lower() == ".png" and _pil_bits(im) == 16 and _pil_channels(im) > 1:
            return _read_png16(p)  # Pillow would reduce 16-bit colour to 8 bits
        im.load()
        if im.mode == "P":
            im = im.convert("RGBA" if "transparency" in im.info else "RGB")
        elif im.mode in ("CMYK", "YCbCr", "1"):
            im = im.convert("RGB" if im.mode != "1" else "L")
        a = np.asarray(im)
    if a.dtype == np.int32:  # mode "I": 16-bit grey PNG read as 32-bit ints
        return np.clip(a, 0, 65535).astype(np.uint16)
    if a.dtype == np.bool_:
        return a.astype(np.uint8) * np.uint8(255)
    return a if a.dtype in (np.uint8, np.uint16) else a.astype(np.float32)


def _read_png16(p: Path | Blob) -> np.ndarray:
    import png

    reader = png.Reader(bytes=p.data) if isinstance(p, Blob) else png.Reader(filename=str(p))
    w, h, rows, meta = reader.asDirect()
    planes = meta["planes"]
    a = np.vstack([np.asarray(r, np.uint16) for r in rows]).reshape(h, w, planes)
    return a if meta["bitdepth"] == 16 else (a.astype(np.float32) / float(2 ** meta["bitdepth"] - 1)).astype(np.float32)


def _read_exr(p: Path) -> np.ndarray:
    """svcore's one EXR reader (RGB, RGBA with alpha dropped, RG, or one channel), its errors as the importer's."""
    from svcore.image_io import ImageError, read_exr_channels

    try:
        return read_exr_channels(p)
    except ImageError as e:
        raise ImportInputError(str(e)) from None
