"""One material folder -> an SVBRDF in DESIGN.md's conventions, with a record of every choice made.

Colour: base colour, diffuse and specular maps in 8/16-bit files are sRGB-encoded and decoded to linear with
colour-science (IEC 61966-2-1); float files (EXR, float TIFF) are linear. Roughness, glossiness, metallic, height
and normal maps are data: no transfer function.

Workflows (docs/IMPORT.md has the derivation and sources):

* metallic/roughness (glTF 2.0 / Burley 2012 / UE4): diffuse = basecolor * (1 - metallic);
  F0 = 0.04 * (1 - metallic) + basecolor * metallic (lerp(0.04, basecolor, metallic), 4 % dielectric F0);
  a folder without a metallic map is a dielectric (metallic = 0).
* specular/glossiness: the colour map is the diffuse albedo, the specular map is F0; roughness = 1 - glossiness
  when only a glossiness map exists.

Data values outside [0, 1] (possible only in float files) are clipped; the clipped fraction is recorded.
Maps of different resolutions within a material are each centre-cropped and resampled to the output size: they
cover the same surface at different sampling rates (libraries ship a 4K colour map with a 2K normal map);
maps of different aspect ratios do not cover the same surface and are refused.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from materials.maps import SVBRDF

from svcore.image_io import srgb_decode

from . import ImportInputError
from . import normals as nm
from .discover import MaterialSource
from .readers import ImageInfo, info, read_raw
from .resample import centre_square, resize, window

COLOUR_ROLES = ("basecolor", "specular")
DIELECTRIC_F0 = 0.04
DEFAULT_ROUGHNESS = 0.5
ASPECT_TOL = 0.01


def crop_of(mat: MaterialSource, crop: float, capture_cm: float | None) -> tuple[float, str]:
    """The crop fraction of one material and how it was decided: ``capture_cm`` over the tile width its
    metadata.json states (``physical_size_cm``, at most 1), else ``crop``.

    Raises:
        ImportInputError: a stated physical size that is not a positive number.
    """
    stated = mat.meta.get("physical_size_cm")
    if capture_cm is None or stated is None:
        return crop, "import.crop"
    if isinstance(stated, bool) or not isinstance(stated, (int, float)) or not stated > 0:
        raise ImportInputError(f"material {mat.name}: metadata.json physical_size_cm must be a positive number "
                               f"(the tile's width in cm), got {stated!r}")
    return min(1.0, capture_cm / float(stated)), f"capture_cm {capture_cm:g} / physical_size_cm {stated:g}"


def centre_of(mat: MaterialSource, centre: tuple[float, float]) -> tuple[tuple[float, float], str | None]:
    """The crop window's centre of one material and, when it is not ``centre`` (import.crop_centre), why: a
    material whose metadata says ``stationary: false`` (MatSynth marks materials whose look changes across the
    tile: one object, a gradient of wear) is cropped at the middle of the tile, where its maker centred it, since a
    window moved elsewhere may show none of it. (With crop 1 the whole tile is kept and the centre does not
    matter.)"""
    if mat.meta.get("stationary") is False:
        return (0.5, 0.5), "stationary: false (cropped at the centre)"
    return (float(centre[0]), float(centre[1])), None


def preflight(mat: MaterialSource, size: int, allow_upscale: bool, crop: float = 1.0) -> dict[str, ImageInfo]:
    """Headers of every map, checked before anything is written.

    ``crop``: the material's crop fraction (:func:`crop_of`): its window must still hold ``size`` pixels.

    Raises:
        ImportInputError: unreadable header, no colour map, a 1-channel normal map, maps of different aspect
            ratios, or a map (its crop window) smaller than ``size`` without ``allow_upscale``.
    """
    infos = {role: info(p) for role, p in mat.files.items()}
    if "basecolor" not in infos:
        raise ImportInputError(f"material {mat.name} ({mat.root}) has no basecolor/albedo/color/diffuse map")
    if "normal" in infos and infos["normal"].channels == 1:
        raise ImportInputError(f"{mat.files['normal']}: a normal map needs 2 or 3 channels, this one has 1 (a height "
                               "or bump map misnamed 'normal'?)")
    aspects = {r: i.width / i.height for r, i in infos.items()}
    ref = aspects["basecolor"]
    for r, a in aspects.items():
        if abs(a / ref - 1) > ASPECT_TOL:
            raise ImportInputError(f"material {mat.name}: {mat.files[r].name} is {infos[r].width}x{infos[r].height}, "
                                   f"the colour map {infos['basecolor'].width}x{infos['basecolor'].height}: different "
                                   "aspect ratios do not cover the same surface")
    small = min(min(i.width, i.height) for i in infos.values())
    if round(small * crop) < size and not allow_upscale:
        if crop < 1:
            raise ImportInputError(f"material {mat.name}: the crop window ({crop:g} of a {small}-pixel map) has "
                                   f"{round(small * crop)} pixels, fewer than --size {size} (pass --allow-upscale "
                                   "to enlarge it, or a larger crop)")
        raise ImportInputError(f"material {mat.name} has a {small}-pixel map, smaller than --size {size} "
                               "(pass --allow-upscale to enlarge it)")
    return infos


@lru_cache(maxsize=2)
def _srgb_lut(bits: int) -> np.ndarray:
    """Linear value of every 8/16-bit sRGB code, computed once with colour-science (calling it per 2048^2 image
    would take seconds)."""
    top = 2 ** bits - 1
    return srgb_decode(np.arange(top + 1, dtype=np.float64) / top).astype(np.float32)


def _grey(a: np.ndarray) -> np.ndarray:
    return a[..., :1] if a.shape[-1] == 1 else a[..., :3].mean(axis=-1, keepdims=True)


def _rgb(a: np.ndarray) -> np.ndarray:
    return np.repeat(a[..., :1], 3, axis=-1) if a.shape[-1] < 3 else a[..., :3]


def convert(mat: MaterialSource, size: int, allow_upscale: bool, convention: str,
            height_strength: float, crop: float = 1.0, centre: tuple[float, float] = (0.5, 0.5),
            crop_how: str = "import.crop") -> tuple[SVBRDF, dict]:
    """Read, decode, resample and convert one material folder.

    Args:
        mat: the material.
        size: output side length.
        allow_upscale: permit maps smaller than ``size``.
        convention: "auto", "opengl" or "directx".
        height_strength: relief of height value 1, in widths of the source tile (height-derived normals and the
            agreement test); a crop window shows 1/crop of it per map width, so slopes scale by 1/crop.
        crop, centre: the window of the centred square that becomes the map (:func:`resample.window`).
        crop_how: how ``crop`` was decided (recorded).

    Returns:
        (maps (size, size, C) float32, record): the record says per map the file, the colour space assumed, the
        clipped fraction; the workflow, the normal convention and how it was decided; warnings.
    """
    infos = preflight(mat, size, allow_upscale, crop)
    rec: dict = {"maps": {}, "warnings": []}
    raw, tileable = {}, crop >= 1
    rec["crop"] = {"fraction": crop, "centre": [float(c) for c in centre], "decided_by": crop_how}
    for role, path in mat.files.items():
        # JPEG: decode at a reduced DCT scale while the window stays >= 2x the output (the last 2x is averaged in
        # linear light)
        a = read_raw(path, min_size=2 * size if crop >= 1 else int(np.ceil(2 * size / crop)))
        decoded = [int(a.shape[1]), int(a.shape[0])]
        if a.shape[0] != a.shape[1]:
            tileable = False
        a = window(centre_square(a), crop, centre)
        if role == "basecolor":
            rec["crop"]["window_pixels"] = int(a.shape[0])  # of the colour map as decoded
        scale = np.float32(1.0)
        if a.dtype.kind == "u":
            if role in COLOUR_ROLES:  # decode before averaging: averages of colour are averages of light
                a = _srgb_lut(a.dtype.itemsize * 8)[_rgb(a)]
            else:  # data are linear in their codes: average the codes (no full-size float copy), then scale
                scale = np.float32(1.0 / np.iinfo(a.dtype).max)
        a = resize(a, size) * scale
        if role == "normal":
            a = nm.decode(a, path)
            space = "data: (n+1)/2" if not infos[role].float_linear else "data: n"
        elif role in COLOUR_ROLES:
            a = _rgb(a)
            space = ("linear (float file)" if infos[role].float_linear
                     else "sRGB IEC 61966-2-1 -> linear (colour-science)")
        else:
            a = _grey(a)
            space = "data (no transfer function)"
        entry = {"file": path.name, "space": space, "source_size": [infos[role].width, infos[role].height],
                 "bits": infos[role].bits}
        if decoded != entry["source_size"]:
            entry["decoded_size"] = decoded  # JPEG decoded at a reduced DCT scale
        if role not in ("normal", "height"):
            out = float(((a < 0) | (a > 1)).mean())
            if out > 0:
                entry["clipped_fraction"] = out
                rec["warnings"].append(f"{path.name}: {out:.2%} of values outside [0, 1] clipped")
            a = np.clip(a, 0.0, 1.0)
        rec["maps"][role] = entry
        raw[role] = a.astype(np.float32)
    rec["tileable"] = tileable
    base = raw["basecolor"]
    if "specular" in raw:
        rec["workflow"] = "specular"
        diffuse, spec = base, raw["specular"]
        if "metallic" in raw:
            rec["warnings"].append(f"{mat.files['metallic'].name}: ignored, the specular map gives F0")
    else:
        rec["workflow"] = "metallic"
        m = raw.get("metallic", np.zeros_like(base[..., :1]))
        diffuse = base * (1.0 - m)
        spec = DIELECTRIC_F0 * (1.0 - m) + base * m
    if "roughness" in raw:
        rough = raw["roughness"]
    elif "glossiness" in raw:
        rough = 1.0 - raw["glossiness"]
        rec["roughness_from"] = "1 - glossiness"
    else:
        rough = np.full_like(base[..., :1], DEFAULT_ROUGHNESS)
        rec["warnings"].append(f"no roughness or glossiness map: constant roughness {DEFAULT_ROUGHNESS}")
    normal = _normals(mat, raw, convention, height_strength / crop, rec)
    maps = SVBRDF(normal=normal, diffuse=np.clip(diffuse, 0, 1).astype(np.float32),
                  specular=np.clip(spec, 0, 1).astype(np.float32), roughness=np.clip(rough, 0, 1).astype(np.float32))
    return maps.validate(normal_tol=1e-3), rec


def _normals(mat: MaterialSource, raw: dict, convention: str, strength: float, rec: dict) -> np.ndarray:
    h = raw.get("height")
    if "normal" not in raw:
        if h is not None:
            rec["normal"] = {"from": "height", "height_strength": strength}
            return nm.from_height(h[..., 0], strength)
        rec["normal"] = {"from": "flat"}
        rec["warnings"].append("no normal or height map: flat normals")
        return np.tile(np.array([0, 0, 1], np.float32), raw["basecolor"].shape[:2] + (1,))
    v = raw["normal"]
    said = mat.conventions.get("normal")
    agree = nm.height_agreement(v, h[..., 0], strength) if h is not None else None
    if convention != "auto":
        conv, how = convention, "--normal-convention"
    elif said:
        conv, how = said, "file name"
    elif agree is not None and abs(agree[1]) >= nm.MIN_AGREEMENT:
        conv, how = ("opengl" if agree[1] > 0 else "directx"), "height gradient agreement"
    else:
        conv, how = "opengl", "assumed (no name hint, no usable height map)"
    rec["normal"] = {"from": "normal map", "convention": conv, "decided_by": how}
    if agree is not None:
        rec["normal"]["height_correlation_xy"] = [round(agree[0], 4), round(agree[1], 4)]
        if abs(agree[1]) >= nm.MIN_AGREEMENT and (agree[1] > 0) != (conv == "opengl"):
            rec["warnings"].append(f"normal map is taken as {conv} ({how}) but its slopes disagree with the height "
                                   f"map's (y correlation {agree[1]:.2f})")
    return nm.finish(v, conv == "directx")
