"""The reference renders store (issue #21): real material folders imported (:mod:`pipeline.importer`) at a stated
physical scale and rendered with the training data's views (:mod:`pipeline.render`), so that `svtrain
eval-reference` measures a run on real materials beside the held-out and stress suites.

``OUT/materials.zarr`` (the imported variants store) and ``OUT/renders.zarr`` (its renders). With no sources (the
default params.yaml) nothing is written but ``OUT`` itself, and the caller says so: the DVC stage stays cheap.
"""
from __future__ import annotations

from pathlib import Path

from .config import ImportConfig, ReferenceConfig, RenderConfig

MATERIALS, RENDERS = "materials.zarr", "renders.zarr"


def run_reference(out_dir: str | Path, cfg: ReferenceConfig, render: RenderConfig, workers: int = 2,
                  scheduler_address: str | None = None) -> tuple[Path | None, int]:
    """Import ``cfg.sources`` into ``out_dir/materials.zarr`` and render it into ``out_dir/renders.zarr``.

    Args:
        out_dir: folder of the two stores (made if missing).
        cfg: sources, map side and crop of the import.
        render: the render settings (those of the training data: the same views).

    Returns:
        (renders store path, number of materials), or (None, 0) when ``cfg.sources`` is empty.

    Raises:
        ImportInputError, ConfigError, StoreError: bad sources (e.g. a folder with no usable material: one line
            naming it), options or output.
    """
    from svcore.config import build

    from .importer.job import run_import
    from .render.stage import run_render

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if not cfg.sources:
        return None, 0
    icfg = build(ImportConfig, sources=tuple(cfg.sources), size=cfg.size, crop=cfg.crop)
    materials, mats = run_import(out / MATERIALS, icfg, workers=workers, scheduler_address=scheduler_address)
    path = run_render([materials], out / RENDERS, render, workers=workers, scheduler_address=scheduler_address)
    return Path(path), len(mats)
