"""The importer's layouts, a registry: layout name -> how that kind of source becomes materials.

A :class:`Layout` says how to find the materials of the sources (cheaply: names, files, metadata), how to check them
before anything is written (every header; a layout may skip a bad item with its reason instead of refusing the
import), what to record of each before conversion, and how to convert a chunk's materials. `svgen import --layout
NAME` picks one; ``auto`` takes the first, in registry order, whose ``detect`` accepts the sources.

* ``matsynth``: parquet shards, one material per row (:mod:`.parquet`); bad rows are skipped, one line each.
* ``deschaintre``: the 2018 dataset's 5-tile strips (:mod:`.strips`), the only layout with photographs.
* ``folders``: one material per folder of map files (:mod:`.discover`); bad input refuses the import.

Every layout of maps converts with the one conversion (:func:`convert_material`, :func:`.convert.convert`).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

from . import parquet
from .convert import centre_of, convert, crop_of, preflight
from .discover import MaterialSource, find_folders, walk
from .strips import find_strips, split, tile_size
from . import ImportInputError

Converted = tuple  # (image (S, S, 3) float32 or None, SVBRDF, record)


@dataclass(frozen=True)
class Layout:
    """One kind of source.

    Attributes:
        find: ``(sources, cfg) -> (materials, skipped)``: every material of the sources, in store order (nothing
            decoded); ``skipped``: items left out, with :meth:`~.parquet.Skipped.line`.
        check: ``(materials, cfg) -> (materials, skipped)``: the first ``cfg.limit`` materials that pass every
            check made before writing (headers, sizes, aspect ratios), and the ones skipped.
        describe: ``(material, cfg, source root) -> dict``: the provenance recorded per material (the source and
            the bytes it read identify the import: resuming against changed sources is refused).
        convert: ``(materials, cfg) -> iterator of (image or None, maps, record)``, in order.
        detect: ``sources -> bool``: whether ``--layout auto`` takes this layout.
        photos: whether its items hold a photograph (``--as renders``).
        crops: whether import.crop and import.capture_cm apply (the 2018 strips are published captures).
        splits: whether its sources name splits (``--split``).
    """

    find: Callable[[list[Path], object], tuple[list[MaterialSource], list]]
    check: Callable[[list[MaterialSource], object], tuple[list[MaterialSource], list]]
    describe: Callable[[MaterialSource, object, Path], dict]
    convert: Callable[[list[MaterialSource], object], Iterator[Converted]]
    detect: Callable[[list[Path]], bool]
    photos: bool = False
    crops: bool = True
    splits: bool = False


LAYOUTS: dict[str, Layout] = {}


def register_layout(name: str, layout: Layout) -> Layout:
    LAYOUTS[name] = layout
    return layout


def detect_layout(sources: list[Path]) -> str:
    """The first registered layout whose ``detect`` accepts the sources (``folders`` accepts any)."""
    return next(name for name, layout in LAYOUTS.items() if layout.detect(sources))


def category_of(m: MaterialSource, cfg) -> str:
    """The material's category: its metadata's, else import.category, else "imported" ('/' would split a preset
    name)."""
    c = str(m.meta.get("category") or cfg.category or "imported")
    return c.replace("/", "-")


def convert_material(m: MaterialSource, cfg) -> Converted:
    """One material of maps converted: its crop (physical scale) and the window's centre decided, then
    :func:`.convert.convert`; no photograph."""
    crop, how = crop_of(m, cfg.crop, cfg.capture_cm)
    centre, why = centre_of(m, tuple(cfg.crop_centre))
    maps, rec = convert(m, cfg.size, cfg.allow_upscale, cfg.normal_convention, cfg.height_strength, crop, centre,
                        how)
    if why:
        rec["crop"]["centre_decided_by"] = why
    return None, maps, rec


def _preflight(m: MaterialSource, cfg) -> None:
    preflight(m, cfg.size, cfg.allow_upscale, crop_of(m, cfg.crop, cfg.capture_cm)[0])


def _images(sources: list[Path]) -> list[Path]:
    from .aliases import IMAGE_EXTS

    out = []
    for s in sources:
        if s.is_file():
            out.append(s)
        elif s.is_dir():
            out += [d / n for d, names in walk(s) for n in names if n.lower().endswith(IMAGE_EXTS + (".parquet",))]
    return out


def _file_describe(m: MaterialSource, cfg, source_root: Path) -> dict:
    """Provenance of a folder or strip (paths resolved, so spelling-independent)."""
    root = m.root.resolve()
    base = root if root.is_dir() else root.parent  # a strip is a file
    files = {r: str(p.resolve().relative_to(base) if p.resolve().is_relative_to(base) else p.resolve())
             for r, p in m.files.items()}
    d = {"name": m.name, "preset": f"{category_of(m, cfg)}/{m.name}", "source": str(root),
         "source_relative": str(root.relative_to(source_root)) if root.is_relative_to(source_root) else str(root),
         "layout": m.layout, "files": files, "bytes": {r: p.stat().st_size for r, p in m.files.items()},
         "category": category_of(m, cfg), "licence": m.meta.get("licence"), "ignored": m.ignored}
    if m.meta:
        d["sidecar"] = m.meta
    return d


def _first(mats: list, cfg) -> list:
    return mats if cfg.limit is None else mats[:cfg.limit]


def _check_folders(mats: list[MaterialSource], cfg) -> tuple[list[MaterialSource], list]:
    mats = _first(mats, cfg)
    for m in mats:
        _preflight(m, cfg)
    return mats, []


def _check_strips(mats: list[MaterialSource], cfg) -> tuple[list[MaterialSource], list]:
    mats = _first(mats, cfg)
    for m in mats:
        t = tile_size(m)
        if t < cfg.size and not cfg.allow_upscale:
            raise ImportInputError(f"{m.root}: tiles of {t} pixels are smaller than --size {cfg.size} "
                                   "(pass --allow-upscale, or a smaller --size)")
    return mats, []


def _is_strips(sources: list[Path]) -> bool:
    """Every image under the sources is a PNG 5 times as wide as high."""
    from .readers import info

    imgs = _images(sources)
    if imgs and all(p.suffix.lower() == ".png" for p in imgs):
        i = info(imgs[0])
        return i.width == 5 * i.height
    return False


def _is_parquet(sources: list[Path]) -> bool:
    """The sources hold parquet files and no images."""
    found = _images(sources)
    return bool(found) and all(p.suffix.lower() == ".parquet" for p in found)


def _parquet_describe(m: parquet.ParquetMaterial, cfg, source_root: Path) -> dict:
    return {"name": m.name, "preset": f"{category_of(m, cfg)}/{m.name}", **parquet.describe(m, source_root),
            "category": category_of(m, cfg), "licence": m.meta.get("licence"), "sidecar": {
                k: v for k, v in m.meta.items() if k != "metadata"}}


register_layout("matsynth", Layout(
    find=parquet.find,
    check=lambda mats, cfg: parquet.check(mats, cfg, lambda m: _preflight(m, cfg)),
    describe=_parquet_describe,
    convert=lambda mats, cfg: parquet.convert_rows(mats, lambda m: convert_material(m, cfg)),
    detect=_is_parquet, splits=True))
register_layout("deschaintre", Layout(
    find=lambda sources, cfg: (find_strips(sources), []), check=_check_strips, describe=_file_describe,
    convert=lambda mats, cfg: (split(m, cfg.size, cfg.input_space) for m in mats), detect=_is_strips,
    photos=True, crops=False))
register_layout("folders", Layout(
    find=lambda sources, cfg: (find_folders(sources, cfg.normal_convention), []), check=_check_folders,
    describe=_file_describe, convert=lambda mats, cfg: (convert_material(m, cfg) for m in mats),
    detect=lambda sources: True))
