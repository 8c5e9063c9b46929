"""Photos read as the camera meant them (svcore.image_io.read_ldr, used by `svtrain predict`): EXIF orientation,
16-bit PNGs at 16 bits, embedded ICC profiles converted to sRGB (or a one-line warning). Images built here."""
from __future__ import annotations

import logging
import struct
import tempfile

import colour
import numpy as np
import pytest
from PIL import Image, ImageCms

from svcore.image_io import UPRIGHT, read_ldr, write_png16


def _dump(tag: str, got: np.ndarray, want: np.ndarray) -> str:
    """Write got, want and 8x their difference as PNGs for a failing comparison; returns the folder."""
    d = tempfile.mkdtemp(prefix=f"svgen-{tag}-")
    for name, a in (("got", got), ("want", want), ("diff_x8", np.abs(got - want) * 8)):
        Image.fromarray(np.round(np.clip(a, 0, 1) * 255).astype(np.uint8)).save(f"{d}/{name}.png")
    return d


def _asymmetric(h: int, w: int) -> np.ndarray:
    """(h, w, 3) uint8 blocks (8x8, so JPEG keeps them) whose every flip and rotation differs."""
    rng = np.random.default_rng(7)
    blocks = rng.integers(20, 236, (h // 8, w // 8, 3)).astype(np.uint8)
    return np.repeat(np.repeat(blocks, 8, 0), 8, 1)


def _exif(orientation: int) -> Image.Exif:
    e = Image.Exif()
    e[0x0112] = orientation
    return e


def test_jpeg_with_exif_orientation_6_comes_back_upright(tmp_path):
    upright = _asymmetric(48, 80)
    stored = np.rot90(upright, 1)  # a phone held upright stores the sensor's rows: orientation 6 turns them back
    Image.fromarray(np.ascontiguousarray(stored)).save(tmp_path / "p.jpg", quality=98, subsampling=0,
                                                        exif=_exif(6))
    got, want = read_ldr(tmp_path / "p.jpg"), upright / 255.0
    assert got.shape == want.shape, got.shape
    # JPEG at quality 98 without chroma subsampling on flat 8x8 blocks: a code or two of error, far below a block's contrast (~20-200 codes)
    err = np.abs(got - want).mean()
    assert err < 2 / 255, (err, _dump("exif6", got, want))


@pytest.mark.parametrize("orientation", range(1, 9))
def test_orientation_table_matches_pillow(tmp_path, orientation):
    """UPRIGHT (numpy, for 16-bit images) and Pillow's exif_transpose (8-bit path) agree on all 8 orientations."""
    stored = _asymmetric(16, 24)
    Image.fromarray(stored).save(tmp_path / "p.png", exif=_exif(orientation))
    got = read_ldr(tmp_path / "p.png")
    np.testing.assert_array_equal(np.round(got * 255).astype(np.uint8), UPRIGHT[orientation](stored))


def test_16bit_png_keeps_its_low_byte(tmp_path):
    rng = np.random.default_rng(3)
    codes = rng.integers(0, 65536, (20, 30, 3)).astype(np.uint16)  # low bytes random: 8 bits would lose them
    write_png16(tmp_path / "p16.png", codes / 65535.0)
    got = np.round(read_ldr(tmp_path / "p16.png") * 65535).astype(np.int64)
    np.testing.assert_array_equal(got, codes)


def _s15(x: float) -> bytes:
    return struct.pack(">i", int(round(x * 65536)))


def icc_matrix_profile(rgb_to_xyz_d50: np.ndarray, description: str) -> bytes:
    """A minimal ICC v2 display profile: colorants (columns of the D50 matrix) and the sRGB tone curve for each
    channel (a 'para' curve of type 3), as Display P3 defines it. Built here: no .icc file to ship."""
    xyz = lambda v: b"XYZ \0\0\0\0" + b"".join(_s15(c) for c in v)  # noqa: E731
    text = description.encode() + b"\0"
    desc = b"desc\0\0\0\0" + struct.pack(">I", len(text)) + text + b"\0" * 8 + b"\0\0\0" + b"\0" * 67
    para = b"para\0\0\0\0" + struct.pack(">HH", 3, 0) + b"".join(
        _s15(v) for v in (2.4, 1 / 1.055, 0.055 / 1.055, 1 / 12.92, 0.04045))
    d50 = (0.9642, 1.0, 0.8249)
    tags = [(b"desc", desc), (b"wtpt", xyz(d50)), (b"rXYZ", xyz(rgb_to_xyz_d50[:, 0])),
            (b"gXYZ", xyz(rgb_to_xyz_d50[:, 1])), (b"bXYZ", xyz(rgb_to_xyz_d50[:, 2])),
            (b"rTRC", para), (b"gTRC", para), (b"bTRC", para)]
    offset = 128 + 4 + 12 * len(tags)
    table, data = b"", b""
    for sig, body in tags:
        body += b"\0" * (-len(body) % 4)
        table += sig + struct.pack(">II", offset + len(data), len(body))
        data += body
    size = offset + len(data)
    header = (struct.pack(">I", size) + b"\0" * 4 + struct.pack(">I", 0x02100000) + b"mntrRGB XYZ " + b"\0" * 12
              + b"acsp" + b"\0" * 28 + b"".join(_s15(c) for c in d50) + b"\0" * 48)
    assert len(header) == 128
    return header + struct.pack(">I", len(tags)) + table + data


def display_p3() -> bytes:
    p3 = colour.RGB_COLOURSPACES["Display P3"]
    bradford = colour.adaptation.matrix_chromatic_adaptation_VonKries(
        colour.xy_to_XYZ(p3.whitepoint), colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]
                                                         ["D50"]), "Bradford")
    return icc_matrix_profile(bradford @ p3.matrix_RGB_to_XYZ, "Display P3 (test)")


def test_display_p3_png_is_converted_to_srgb(tmp_path):
    rng = np.random.default_rng(5)
    p3_codes = rng.integers(40, 216, (16, 16, 3)).astype(np.uint8)
    Image.fromarray(p3_codes).save(tmp_path / "p3.png", icc_profile=display_p3())
    got = read_ldr(tmp_path / "p3.png")
    # expected with colour-science: P3 codes -> linear P3 -> linear sRGB (same D65 white) -> sRGB codes, clipped
    lin = colour.RGB_to_RGB(colour.cctf_decoding(p3_codes / 255.0, "sRGB"), "Display P3", "sRGB")
    want = colour.cctf_encoding(np.clip(lin, 0, 1), "sRGB")
    # LittleCMS works in 8 bits here with s15.16 colorants: at most a couple of codes from the float reference,
    # while the P3 -> sRGB change itself is tens of codes on saturated pixels (checked next)
    assert np.abs(got - want).max() <= 3 / 255, _dump("p3", got, want)
    assert np.abs(p3_codes / 255.0 - want).max() > 20 / 255  # the test images do need the conversion


def test_srgb_profile_leaves_values_exact(tmp_path):
    codes = _asymmetric(16, 16)
    srgb = ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()
    Image.fromarray(codes).save(tmp_path / "s.png", icc_profile=srgb)
    np.testing.assert_array_equal(np.round(read_ldr(tmp_path / "s.png") * 255).astype(np.uint8), codes)


def test_unusable_profile_warns_in_one_line_and_keeps_values(tmp_path, caplog):
    codes = _asymmetric(16, 16)
    Image.fromarray(codes).save(tmp_path / "bad.png", icc_profile=b"not an icc profile at all" * 8)
    with caplog.at_level(logging.WARNING):
        got = read_ldr(tmp_path / "bad.png")
    np.testing.assert_array_equal(np.round(got * 255).astype(np.uint8), codes)
    msgs = [r.getMessage() for r in caplog.records if "ICC" in r.getMessage()]
    assert len(msgs) == 1 and "\n" not in msgs[0] and "bad.png" in msgs[0], msgs


def test_16bit_png_with_a_profile_warns(tmp_path, caplog):
    """Pillow's LittleCMS binding works on 8-bit images: a 16-bit P3 image is read at 16 bits, unconverted, and
    says so (the alternative, converting at 8 bits, would lose the precision the file was saved for)."""
    codes = np.random.default_rng(2).integers(0, 65536, (8, 8, 3)).astype(np.uint16)
    write_png16(tmp_path / "p.png", codes / 65535.0)
    # the iCCP chunk (profile name, compression method 0, zlib-compressed profile) inserted after IHDR
    import zlib

    data = (tmp_path / "p.png").read_bytes()
    body = b"Display P3\0\0" + zlib.compress(display_p3())
    chunk = struct.pack(">I", len(body)) + b"iCCP" + body + struct.pack(">I", zlib.crc32(b"iCCP" + body))
    (tmp_path / "p3_16.png").write_bytes(data[:33] + chunk + data[33:])  # after the 8-byte signature + IHDR
    with caplog.at_level(logging.WARNING):
        got = np.round(read_ldr(tmp_path / "p3_16.png") * 65535).astype(np.int64)
    np.testing.assert_array_equal(got, codes)
    assert any("16-bit" in r.getMessage() and "ICC" in r.getMessage() for r in caplog.records)


def test_svtrain_predict_reads_photos_upright(tmp_path):
    """train/predict.py's reader goes through read_ldr: the rotated JPEG reaches the network upright (and linear)."""
    from svcore.image_io import srgb_decode
    from train.predict import read_photo

    upright = _asymmetric(48, 80)
    Image.fromarray(np.ascontiguousarray(np.rot90(upright, 1))).save(tmp_path / "p.jpg", quality=98, subsampling=0,
                                                                      exif=_exif(6))
    got = read_photo(tmp_path / "p.jpg")
    assert got.shape == (48, 80, 3)
    want = srgb_decode(upright / 255.0)
    assert np.abs(got - want).mean() < 2 / 255, _dump("predict-exif6", got, want)
