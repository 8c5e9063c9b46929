"""`svgen reference OUT`: real material folders -> OUT/materials.zarr (import at a stated crop) and
OUT/renders.zarr (rendered with the params file's render settings: the training data's views)."""
from __future__ import annotations

import click

from svcore.cli import config_command, require

from ..cli_options import parallel_options
from ..config import ReferenceConfig


@config_command(ReferenceConfig, {"size": "--size", "crop": "--crop"}, name="reference")
@click.argument("paths", nargs=-1, type=click.Path(), metavar="[SRC...] OUT")
@parallel_options
def reference(paths, cfg, workers, scheduler_address):
    """Import the reference folders SRC... (or params.yaml reference.sources) and render them into OUT.

    The render settings come from the same --params file's render section, the training data's views. With no
    sources (the default params.yaml): one line, and OUT is left empty (the DVC stage reference).
    """
    from svcore.config import build, validate

    from ..config import RenderConfig
    from ..reference import run_reference

    require(out=paths)
    *sources, out = paths
    if sources:
        preset = cfg.preset
        cfg = validate(ReferenceConfig, {**cfg.as_dict(), "sources": sources})
        cfg._preset = preset
    ctx = click.get_current_context()
    render = build(RenderConfig, params_file=ctx.params.get("params_file"))  # click's copy: still holds --params
    path, n = run_reference(out, cfg, render, workers=workers, scheduler_address=scheduler_address)
    if path is None:
        click.echo(f"no reference sources (reference.sources is empty): {out} left empty")
        return
    click.echo(f"wrote {path} ({n} materials, crop {cfg.crop:g})")

