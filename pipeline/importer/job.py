"""`svgen import` as a stage: plan the materials, then :class:`pipeline.exec.runner.Stage` runs the chunk tasks that
convert them and writes a variants store (or a renders store for `--as renders`), resumable like every stage.

A chunk task is a pure function of (config, material list, source bytes): the same bytes for any worker count.
What a worker learns about a material (workflow, normal convention decided, clipped values, warnings) goes to a
per-chunk JSON record next to the chunk, written before the chunk's completion marker; the stage's ``finish`` hook
gathers the records into the store's ``materials`` attribute at finalize.
"""
from __future__ import annotations

import dataclasses
import json
import zlib
from pathlib import Path

import numpy as np

from materials.maps import MAP_NAMES

from svcore.errors import ConfigError

from storage.store import recorded_path, side_read, side_remove, side_write, write_chunk
from storage.svbrdf_store import array_specs as svbrdf_array_specs
from storage.svbrdf_store import encode_maps

from . import ImportInputError
from ..config import ImportConfig
from ..exec.runner import Stage
from .convert import crop_of, preflight
from .discover import MaterialSource, find_folders
from .strips import find_strips, tile_size

RECORDS = ".import_records"


def detect_layout(sources: list[Path]) -> str:
    """"deschaintre" when every image under the sources is a PNG 5 times as wide as high, else "folders"."""
    from .aliases import IMAGE_EXTS
    from .discover import walk
    from .readers import info

    imgs = []
    for s in sources:
        if s.is_file():
            imgs.append(s)
        elif s.is_dir():
            imgs += [d / n for d, names in walk(s) for n in names if n.lower().endswith(IMAGE_EXTS)]
    if imgs and all(p.suffix.lower() == ".png" for p in imgs):
        i = info(imgs[0])
        if i.width == 5 * i.height:
            return "deschaintre"
    return "folders"


def plan(cfg: ImportConfig) -> tuple[str, list[MaterialSource]]:
    """The layout and the materials of an import, every header checked (nothing written yet).

    Raises:
        ImportInputError: see :func:`find_folders`, :func:`find_strips`, :func:`preflight`.
    """
    if not cfg.sources:
        raise ImportInputError("no source folder given")
    sources = [Path(s) for s in cfg.sources]
    layout = detect_layout(sources) if cfg.layout == "auto" else cfg.layout
    if cfg.as_kind == "renders" and layout != "deschaintre":
        raise ConfigError("--as renders needs the deschaintre layout (folders hold maps, not photographs)")
    if layout == "deschaintre" and (cfg.crop < 1 or cfg.capture_cm is not None):
        raise ConfigError("import.crop and import.capture_cm apply to material folders, not to 2018 strips (their "
                          "tiles are the published captures)")
    if layout == "deschaintre":
        mats = find_strips(sources)
        for m in mats:
            t = tile_size(m)
            if t < cfg.size and not cfg.allow_upscale:
                raise ImportInputError(f"{m.root}: tiles of {t} pixels are smaller than --size {cfg.size} "
                                       "(pass --allow-upscale, or a smaller --size)")
    else:
        mats = find_folders(sources, cfg.normal_convention)
        for m in mats:
            preflight(m, cfg.size, cfg.allow_upscale, crop_of(m, cfg.crop, cfg.capture_cm)[0])
    return layout, mats


def category_of(m: MaterialSource, cfg: ImportConfig) -> str:
    c = str(m.meta.get("category") or cfg.category or "imported")
    return c.replace("/", "-")


def describe(m: MaterialSource, cfg: ImportConfig, source_root: Path) -> dict:
    """Provenance of a material known before conversion (paths resolved, so spelling-independent)."""
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


def _root_of(m: MaterialSource, sources: list[Path]) -> Path:
    r = m.root.resolve()
    for s in sources:
        s = s.resolve()
        if r == s or r.is_relative_to(s):
            return s
    return r.parent


def _convert(m: MaterialSource, cfg: ImportConfig):
    """(image or None, maps, record) of one material."""
    if m.layout == "deschaintre":
        from .strips import split

        return split(m, cfg.size, cfg.input_space)
    from .convert import convert

    crop, how = crop_of(m, cfg.crop, cfg.capture_cm)
    maps, rec = convert(m, cfg.size, cfg.allow_upscale, cfg.normal_convention, cfg.height_strength, crop,
                        tuple(cfg.crop_centre), how)
    return None, maps, rec


def _chunk_task(c: int, threads: int, *, partial: str, mats: list[MaterialSource], cfg: ImportConfig) -> int:
    """Worker: convert the materials of chunk ``c``, record what was decided, write the whole chunk."""
    start, stop = c * cfg.chunk, min(len(mats), (c + 1) * cfg.chunk)
    maps = {k: [] for k in MAP_NAMES}
    images, records = [], []
    for m in mats[start:stop]:
        image, svbrdf, rec = _convert(m, cfg)
        for k, v in encode_maps(svbrdf).items():
            maps[k].append(v)
        if image is not None:
            from ..render.encoding import encode_srgb8

            images.append(encode_srgb8(image)[None])
        records.append(rec)
    n = stop - start
    data = {k: np.stack(v) for k, v in maps.items()}
    data["seed"] = np.array([zlib.crc32(m.name.encode()) for m in mats[start:stop]], np.uint64)
    data["preset"] = np.array([[i, -1] for i in range(start, stop)], np.int32)
    if cfg.as_kind == "renders":
        from ..render.views import ViewParams  # loads mitsuba: only for renders stores

        data["image"] = np.stack(images)
        data["view"] = np.tile(ViewParams(light_x=0.0, light_y=0.0).as_array(), (n, 1, 1))
        data["source"] = np.arange(start, stop, dtype=np.int64)
        data["source_seed"] = data.pop("seed")
        data["input"] = np.zeros(n, np.int16)
        data["category"] = np.full(n, -1, np.int16)
    # before write_chunk's marker: a marked chunk always has its record
    side_write(partial, f"{RECORDS}/{c}.json", json.dumps(records, sort_keys=True).encode())
    write_chunk(partial, c, start, data)
    return n


def _gather_records(described: list[dict], n_chunks: int, out: list):
    """The stage's finish hook: per-chunk records -> the ``materials`` attribute (also appended to ``out``)."""

    def finish(partial: Path | str) -> dict:
        recs = [r for c in range(n_chunks) for r in json.loads(side_read(partial, f"{RECORDS}/{c}.json"))]
        # source folders recorded relative to the store's directory (the partial's is the final's), like every input
        out.extend({**d, "source": recorded_path(d["source"], partial), **r} for d, r in zip(described, recs))
        side_remove(partial, RECORDS)
        return {"materials": out}

    return finish


def import_stage(cfg: ImportConfig) -> tuple[Stage, list]:
    """The import stage of ``cfg`` (sources planned and checked; nothing written) and the list that receives the
    per-material records (with their warnings) when the stage finishes.

    Raises:
        ImportInputError, ConfigError: bad sources or options.
    """
    layout, mats = plan(cfg)
    sources = [Path(s) for s in cfg.sources]
    described = [describe(m, cfg, _root_of(m, sources)) for m in mats]
    names = [d["preset"] for d in described]
    # the materials found (names, files within their source folder, sizes) are the config's identity of the sources:
    # resuming against changed sources is refused, any spelling or location of the same sources accepted (#15: input
    # paths never enter the config hash)
    config = {**{k: v for k, v in cfg.as_dict().items() if k != "sources"}, "layout": layout,
              "materials": [{k: d[k] for k in ("name", "source_relative", "files", "bytes")} for d in described]}
    fixed = {"presets": names, "param_names": {}, "categories": []}
    if cfg.as_kind == "renders":
        from ..render.scene import scene_constants
        from ..render.store import KIND, array_specs

        size = cfg.size
        arrays = array_specs(1, size, size)
        fixed.update({"scene": {**scene_constants(), "light_model": "unknown (photographs from the 2018 strips)",
                                "output": f"the strips' input tiles, read as {cfg.input_space}"},
                      "view_distribution": {"identity": "zoom 1, rotation 0, shift 0; light position unknown (0, 0)"},
                      "aligned_maps": "recomputed: pipeline.render.views.transform_maps(base maps, view, res)"})
        kind = KIND
    else:
        arrays = svbrdf_array_specs("variants", cfg.size, 0)  # no params: imported materials have none
        arrays["seed"] = dataclasses.replace(arrays["seed"], encoding="crc32 of the material name")
        kind = "variants"

    def attrs(out: Path) -> dict:  # the source folders relative to the output's directory (storage.store)
        srcs = [recorded_path(s, out) for s in cfg.sources]
        a = {**fixed, "import": {"layout": layout, "sources": srcs, "seed": "crc32 of the material name (import is "
                                 "deterministic; the value only identifies it)",
                                 # physical scale: which part of each source became the map (per material:
                                 # attrs.materials[i].crop)
                                 "crop": {"fraction": cfg.crop, "centre": list(cfg.crop_centre),
                                          "capture_cm": cfg.capture_cm}}}
        if kind == "renders":
            a["inputs"] = [{"path": srcs[0], "kind": "deschaintre-strips", "n": len(mats), "config_hash": ""}]
        return a

    records: list = []
    n_chunks = -(-len(mats) // cfg.chunk)
    stage = Stage(kind, len(mats), cfg.chunk, arrays, config, attrs, _chunk_task, dict(mats=mats, cfg=cfg),
                  desc="import", unit="material", inputs=tuple(cfg.sources),
                  finish=_gather_records(described, n_chunks, records))
    return stage, records


def run_import(out, cfg: ImportConfig, workers: int = 2, scheduler_address: str | None = None) -> tuple[str, list]:
    """Import the sources of ``cfg`` into a store at ``out`` (resuming an interrupted run).

    Returns:
        (store path, per-material records with their warnings).

    Raises:
        ImportInputError, ConfigError, StoreError: bad sources, options or output (nothing written).
    """
    stage, records = import_stage(cfg)
    return stage.run(out, workers, scheduler_address), records
