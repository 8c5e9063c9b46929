"""``svtrain predict PHOTO... | FOLDER``: maps from flash photos, at the size people capture.

The network is fully convolutional, so it predicts at any ``--size`` that is a multiple of its stride (2^levels):
default 256, the paper's capture size, whatever crop it was trained at. Larger sizes run (the paper found the
quality falls off above 256: its network saw 256² crops; a note says so). Each photo is centre-cropped to a square
and resized to ``size``. Photos are read in an input space (``--input-space``): ``auto`` takes PNG/JPEG as
sRGB-encoded (linearised with colour-science) and EXR as linear; ``srgb``/``linear`` force one. The 2018 paper's
own data are PNGs that hold *linear* values: read those with ``--input-space linear`` (the gamma confusion users
of the original code kept hitting). EXR values above 1 are clipped: the network was trained on LDR renders.

Outputs per photo, in its own folder: ``{normal,diffuse,roughness,specular}.png`` (normal encoded (n+1)/2,
the others sRGB-encoded for viewing), the same maps as linear ``.exr`` (normal as the raw unit vector),
``input.png`` (what the network saw), ``rerender.png`` (the maps under a moved flash) and ``prediction.json``
(checkpoint, config, input space, size, svgen version, ``input_check``: simple statistics of the input and a
warning flag when the photo is far from the training distribution, :mod:`train.photo_check`, and ``specular_copy``:
the predicted specular's correlation with the diffuse and its chroma, :mod:`train.spec_stats`). Photos that cannot be
read are listed at the end (one line, non-zero exit) after every readable one has been written. Without a checkpoint
the model shipped in the package runs (:mod:`train.bundled_model`).
"""
from __future__ import annotations

from pathlib import Path

import json
from dataclasses import dataclass

import numpy as np
import torch
from torch.nn import functional as F

from svcore.errors import ConfigError, SvgenError
from svcore.image_io import ImageError, read_exr, read_ldr, srgb_decode, srgb_encode, write_exr, write_png
from svcore.log import get_logger
from svcore.outputs import refuse_existing
from svcore.progress import progress

from .brdf import DIFFUSE, NORMAL, ROUGHNESS, SPECULAR
from . import bundled_model, photo_check, predict_memory
from .checkpoint import load_model
from .render import flash_render
from .spec_stats import spec_stats

log = get_logger(__name__)

MIN_SIDE = 32
LDR_SUFFIXES = (".png", ".jpg", ".jpeg")
PHOTO_SUFFIXES = LDR_SUFFIXES + (".exr",)
#: the paper's capture and training size; ``--size`` default.
DEFAULT_SIZE = 256
#: ``--input-space`` values: auto = sRGB for PNG/JPEG, linear for EXR.
INPUT_SPACES = ("auto", "srgb", "linear")
#: light offset of the re-rendering written beside the maps (the capture flash sits near the centre).
MOVED_LIGHT = (0.6, 0.4)


def input_space_of(path: str | Path, space: str = "auto") -> str:
    """The space a photo's values are in: ``srgb`` or ``linear`` (``auto``: by file type)."""
    if space not in INPUT_SPACES:
        raise ConfigError(f"unknown input space {space!r}; use one of {', '.join(INPUT_SPACES)}")
    if space != "auto":
        return space
    return "linear" if Path(path).suffix.lower() == ".exr" else "srgb"


def read_photo(path: str | Path, space: str = "auto") -> np.ndarray:
    """A photo as (H, W, 3) float32 linear in [0, 1].

    Args:
        path: PNG, JPEG or EXR file.
        space: ``auto``, ``srgb`` or ``linear`` (see :func:`input_space_of`).

    Raises:
        ImageError: missing/unreadable file, unknown format, too small, non-finite values.
    """
    p = Path(path)
    if not p.is_file():
        raise ImageError(f"photo {str(p)!r} does not exist")
    suffix = p.suffix.lower()
    if suffix in LDR_SUFFIXES:
        img = read_ldr(p)
    elif suffix == ".exr":
        img = read_exr(p)
        if not np.all(np.isfinite(img)):
            raise ImageError(f"{p} has non-finite pixels")
        img = np.clip(img, 0.0, 1.0)
    else:
        raise ImageError(f"{p}: unsupported format {suffix or '(none)'}; use PNG, JPEG or EXR")
    if input_space_of(p, space) == "srgb":
        img = srgb_decode(img)
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


#: the maps in the order of the previews and output files.
PREVIEW_MAPS = {"normal": NORMAL, "diffuse": DIFFUSE, "roughness": ROUGHNESS, "specular": SPECULAR}


def map_previews(maps: torch.Tensor) -> dict[str, np.ndarray]:
    """The DESIGN.md display encodings of packed maps (1, 10, H, W): {name: (H, W, C) values in [0, 1]}, normal
    as (n + 1) / 2 (C = 3), diffuse and specular sRGB-encoded (C = 3), roughness as is (C = 1)."""
    out = {}
    for name, sl in PREVIEW_MAPS.items():
        a = _hwc(maps[:, sl])
        # Roughness is a perceptual parameter, not a colour: shown as is, not sRGB-encoded.
        out[name] = (a + 1.0) * 0.5 if name == "normal" else a if name == "roughness" else srgb_encode(a)
    return out


def write_maps(maps: torch.Tensor, out: Path) -> list[Path]:
    """Write packed maps (1, 10, H, W) as PNG previews (:func:`map_previews`) and linear EXRs."""
    written = []
    for name, img in map_previews(maps).items():
        written.append(write_png(out / f"{name}.png", img))
        written.append(write_exr(out / f"{name}.exr", _hwc(maps[:, PREVIEW_MAPS[name]])))
    return written


def check_size(size: int, stride: int) -> None:
    """Refuse a prediction size the network cannot take.

    Raises:
        ConfigError: not a positive multiple of the network's stride (2^levels).
    """
    if size < stride or size % stride:
        raise ConfigError(f"--size {size} is not a positive multiple of the network's stride {stride} "
                          f"(2^levels); try {max(stride, round(size / stride) * stride)}")


def note_size(size: int) -> None:
    """Note a size above the paper's (after the checks: a refused size gets its one line alone)."""
    if size > DEFAULT_SIZE:
        log.warning("predicting at %d²: allowed, but the paper found the quality falls off above 256 "
                    "(its network saw 256² crops)", size)


def collect_photos(inputs: list[str | Path]) -> list[Path]:
    """The photos named by ``inputs``: files as given, folders expanded to their PNG/JPEG/EXR files (sorted).

    Raises:
        ImageError: no input, or a folder without a single photo.
    """
    if not inputs:
        raise ImageError("give a photo or a folder of photos")
    photos = []
    for inp in map(Path, inputs):
        if inp.is_dir():
            found = sorted(p for p in inp.iterdir() if p.is_file() and p.suffix.lower() in PHOTO_SUFFIXES)
            if not found:
                raise ImageError(f"folder {str(inp)!r} holds no PNG, JPEG or EXR photos")
            photos.extend(found)
        else:
            photos.append(inp)  # missing/foreign files are reported per photo
    return photos


def output_dirs(photos: list[Path], inputs: list[str | Path], out: str | Path | None) -> list[Path]:
    """One output folder per photo: ``out`` itself for a single photo file; else ``out/<stem>`` (default ``out``:
    ``<folder>_maps`` for one folder, each photo's ``<stem>_maps`` beside it otherwise)."""
    single = len(inputs) == 1 and not Path(inputs[0]).is_dir()
    if single:
        return [Path(out) if out else photos[0].with_name(photos[0].stem + "_maps")]
    if out is None and len(inputs) == 1:
        d = Path(inputs[0])
        out = d.with_name(d.name + "_maps")
    dirs, seen = [], set()
    for p in photos:
        name = p.stem if p.stem not in seen else p.name.replace(".", "_")  # a.png and a.exr side by side
        seen.add(name)
        dirs.append(Path(out) / name if out else p.with_name(p.stem + "_maps"))
    return dirs


@dataclass
class Prediction:
    """What ``predict_many`` did: the folders written, and the photos that could not be read with why."""

    written: list[Path]
    failed: list[tuple[Path, str]]


def svgen_version() -> str:
    """The running svgen code: package version and source digest (:func:`svcore.versions.svgen_version`)."""
    from svcore.versions import svgen_version as version

    return version()


@torch.no_grad()
def predict_many(inputs: list[str | Path], checkpoint_path: str | Path | None, out: str | Path | None = None,
                 size: int = DEFAULT_SIZE, input_space: str = "auto", batch_size: int = 8,
                 device: str = "cpu", show_progress: bool | None = None, force: bool = False) -> Prediction:
    """Predict maps for photos and folders of photos, ``batch_size`` photos per network call.

    A photo's output folder that already holds files is refused before any work unless ``force``
    (:func:`svcore.outputs.refuse_existing`, the rule of every command).
    ``checkpoint_path``: a checkpoint file or run directory; None or ``"bundled"``: the model shipped in the package.

    Returns:
        the folders written and the photos that failed (each with its one-line reason); the caller decides the
        exit status.
    """
    from .device import resolve_device

    if input_space not in INPUT_SPACES:
        raise ConfigError(f"unknown input space {input_space!r}; use one of {', '.join(INPUT_SPACES)}")
    if batch_size < 1:
        raise ConfigError(f"--batch must be >= 1, got {batch_size}")
    dev = resolve_device(device)
    photos = collect_photos(inputs)
    dirs = output_dirs(photos, inputs, out)
    refuse_existing(dirs, force)
    checkpoint_path = bundled_model.resolve(bundled_model.NAME if checkpoint_path is None else checkpoint_path)
    model, cfg = load_model(checkpoint_path)
    check_size(size, 2 ** cfg.model.levels)
    # before any large allocation: a size or batch that cannot fit is one line, not an allocator's traceback
    predict_memory.check(model, 2 ** cfg.model.levels, size, min(batch_size, len(photos)), dev)
    note_size(size)
    model.to(dev)
    meta = {"checkpoint": str(Path(checkpoint_path).resolve()), "config": cfg.to_dict(), "size": size,
            "svgen_version": svgen_version(), "torch_version": torch.__version__, "device": str(dev),
            **({"note": "above 256: the paper found the quality falls off (its network saw 256² crops)"}
               if size > DEFAULT_SIZE else {})}
    written, failed = [], []
    bar = progress(total=len(photos), desc="predict", unit="photo",
                   disable=None if show_progress is None else not show_progress)
    for lo in range(0, len(photos), batch_size):
        batch = []
        for photo, d in zip(photos[lo:lo + batch_size], dirs[lo:lo + batch_size]):
            try:
                img = read_photo(photo, input_space)
            except SvgenError as e:
                failed.append((photo, str(e).splitlines()[0]))
                bar.update(1)
                continue
            side = min(img.shape[:2])
            if side < size:  # the maps can hold no detail the photo lacks: say so rather than upscale in silence
                log.warning("%s: its centre square (%d²) is upscaled %.1fx to %d²; the maps hold no finer detail "
                            "than the photo (use a larger photo or a smaller --size)", photo.name, side, size / side,
                            size)
            batch.append((photo, d, img.shape[:2], side, to_network_input(img, size)))
        if not batch:
            continue
        x = torch.cat([b[4] for b in batch]).to(dev)
        maps = model(x).float()
        rer = flash_render(maps, torch.tensor(MOVED_LIGHT))
        maps, x, rer = maps.cpu(), x.cpu(), rer.cpu()
        copy_stats = spec_stats(maps)  # does the specular repeat the photo? (no ground truth needed)
        for k, (photo, d, hw, side, _) in enumerate(batch):
            checked = photo_check.check(x[k])
            if checked["warnings"]:
                log.warning("%s is far from the training photos (%s): the maps may be wrong", photo.name,
                            "; ".join(checked["warnings"]))
            d.mkdir(parents=True, exist_ok=True)
            write_maps(maps[k:k + 1], d)
            write_png(d / "input.png", srgb_encode(_hwc(x[k:k + 1])))
            write_png(d / "rerender.png", srgb_encode(_hwc(rer[k:k + 1])))
            (d / "prediction.json").write_text(json.dumps({
                "photo": str(Path(photo).resolve()), "photo_size": list(hw), "crop": "centre square, resized",
                # > 1: the centre square was enlarged to --size (a warning said so)
                "upscale": round(size / side, 4),
                "input_space": input_space_of(photo, input_space), "input_space_option": input_space,
                "input_check": checked,
                "specular_copy": {s: round(float(v[k]), 6) for s, v in copy_stats.items()}, **meta},
                indent=2) + "\n")
            written.append(d)
            bar.update(1)
    bar.close()
    return Prediction(written, failed)


def predict(photo: str | Path, checkpoint_path: str | Path | None, out_dir: str | Path, size: int = DEFAULT_SIZE,
            input_space: str = "auto", force: bool = False) -> list[Path]:
    """Run the network on one photo and write its maps into ``out_dir``; returns the written files."""
    res = predict_many([photo], checkpoint_path, out_dir, size, input_space, show_progress=False,
                       force=force)  # None: bundled
    if res.failed:
        raise ImageError(res.failed[0][1])
    return sorted(p for p in Path(out_dir).iterdir() if p.is_file())


__all__ = ["predict", "predict_many", "read_photo", "to_network_input", "map_previews", "write_maps", "ImageError"]
