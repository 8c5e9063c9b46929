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
from .discover import MaterialSource
from .layouts import LAYOUTS, category_of, detect_layout

RECORDS = ".import_records"


def plan(cfg: ImportConfig) -> tuple[str, list[MaterialSource], list]:
    """The layout, the materials of an import and the items skipped (with their reasons), every header checked
    (nothing written yet).

    Raises:
        ImportInputError: bad sources (see the layout's find and check), or nothing left to import.
        ConfigError: options the layout does not take.
    """
    if not cfg.sources:
        raise ImportInputError("no source folder given")
    sources = [Path(s) for s in cfg.sources]
    name = detect_layout(sources) if cfg.layout == "auto" else cfg.layout
    layout = LAYOUTS[name]
    if cfg.as_kind == "renders" and not layout.photos:
        raise ConfigError(f"--as renders needs the deschaintre layout ({name} sources hold maps, not photographs)")
    if not layout.crops and (cfg.crop < 1 or cfg.capture_cm is not None):
        raise ConfigError("import.crop and import.capture_cm apply to material folders and parquet rows, not to "
                          "2018 strips (their tiles are the published captures)")
    if cfg.split and not layout.splits:
        raise ConfigError(f"--split names parquet shards (the matsynth layout), not {name} sources")
    mats, skipped = layout.find(sources, cfg)
    if cfg.only_category:
        found = sorted({category_of(m, cfg) for m in mats})
        mats = [m for m in mats if category_of(m, cfg) in cfg.only_category]
        if not mats:
            raise ImportInputError(f"no material of categor{'y' if len(cfg.only_category) == 1 else 'ies'} "
                                   f"{', '.join(cfg.only_category)}; the sources have: {', '.join(found) or 'none'}")
    mats, more = layout.check(mats, cfg)
    skipped = skipped + more
    if not mats:
        raise ImportInputError("nothing to import: every item was skipped\n" + "\n".join(s.line() for s in skipped))
    return name, mats, skipped


def _root_of(m: MaterialSource, sources: list[Path]) -> Path:
    r = m.root.resolve()
    for s in sources:
        s = s.resolve()
        if r == s or r.is_relative_to(s):
            return s
    return r.parent


def _chunk_task(c: int, threads: int, *, partial: str, mats: list[MaterialSource], cfg: ImportConfig) -> int:
    """Worker: convert the materials of chunk ``c``, record what was decided, write the whole chunk."""
    start, stop = c * cfg.chunk, min(len(mats), (c + 1) * cfg.chunk)
    maps = {k: [] for k in MAP_NAMES}
    images, records = [], []
    for image, svbrdf, rec in LAYOUTS[mats[start].layout].convert(mats[start:stop], cfg):
        for k, v in encode_maps(svbrdf).items():
            maps[k].append(v)
        if image is not None:
            from storage.srgb8 import encode_srgb8

            images.append(encode_srgb8(image)[None])
        records.append(rec)
    n = stop - start
    data = {k: np.stack(v) for k, v in maps.items()}
    data["seed"] = np.array([zlib.crc32(m.name.encode()) for m in mats[start:stop]], np.uint64)
    data["preset"] = np.array([[i, -1] for i in range(start, stop)], np.int32)
    if cfg.as_kind == "renders":
        from storage.views import ViewParams  # loads mitsuba: only for renders stores

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
    layout, mats, skipped = plan(cfg)
    sources = [Path(s) for s in cfg.sources]
    described = [LAYOUTS[layout].describe(m, cfg, _root_of(m, sources)) for m in mats]
    names = [d["preset"] for d in described]
    # the materials found (names, files within their source folder or rows of their shard, sizes) are the config's
    # identity of the sources: resuming against changed sources is refused, any spelling or location of the same
    # sources accepted (#15: input paths never enter the config hash)
    drop = ("sources",) + cfg.dropped_keys()
    config = {**{k: v for k, v in cfg.as_dict().items() if k not in drop}, "layout": layout,
              "materials": [{k: d[k] for k in ("name", "source_relative", "row", "files", "bytes") if k in d}
                            for d in described]}
    fixed = {"presets": names, "param_names": {}, "categories": []}
    if cfg.as_kind == "renders":
        from ..render.scene import scene_constants
        from storage.renders_store import KIND, array_specs

        size = cfg.size
        arrays = array_specs(1, size, size)
        fixed.update({"scene": {**scene_constants(), "light_model": "unknown (photographs from the 2018 strips)",
                                "output": f"the strips' input tiles, read as {cfg.input_space}"},
                      "view_distribution": {"identity": "zoom 1, rotation 0, shift 0; light position unknown (0, 0)"},
                      "aligned_maps": "recomputed: storage.views.transform_maps(base maps, view, res)"})
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
        if skipped:  # the rows left out, one reason each (svgen import prints them at the end)
            a["import"]["skipped"] = [x.as_dict() for x in skipped]
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
