"""`svgen import SRC... OUT`: material folders or the 2018 strips -> a variants store (or a renders store)."""
from __future__ import annotations

import click

from .cli_options import config_options, parallel_options
from .config import IMPORT_LAYOUTS, NORMAL_CONVENTIONS, ImportConfig, build


@click.command("import")
@click.argument("paths", nargs=-1, required=True, type=click.Path())
@click.option("--layout", type=click.Choice(IMPORT_LAYOUTS), default=None,
              help="folders: one material per folder of maps; deschaintre: 2018 5-tile strips [default: auto].")
@click.option("--size", type=int, default=None, help="Output map side, centre crop + area average [default: 256].")
@click.option("--normal-convention", type=click.Choice(NORMAL_CONVENTIONS), default=None,
              help="auto: file name, else height-gradient agreement, else OpenGL [default: auto].")
@click.option("--category", default=None, help="Category of materials without a metadata.json category.")
@click.option("--allow-upscale", is_flag=True, default=None, help="Accept maps smaller than --size.")
@click.option("--as", "as_kind", type=click.Choice(["variants", "renders"]), default=None,
              help="renders: the strips' photos as a one-view renders store (deschaintre layout) [default: variants].")
@click.option("--input-space", type=click.Choice(["linear", "srgb"]), default=None,
              help="Deschaintre layout: encoding of the strips' photos [default: linear, as the 2018 code].")
@click.option("--height-strength", type=float, default=None,
              help="Relief of height 1 in tile widths, for height-derived normals [default: 0.02].")
@click.option("--chunk", type=int, default=None, help="Materials per zarr chunk [default: 4].")
@click.option("--allow-empty", is_flag=True,
              help="With no sources (an empty import.sources in params.yaml): write nothing and succeed (DVC).")
@config_options("import")
@parallel_options
def import_(paths, layout, size, normal_convention, category, allow_upscale, as_kind, input_space, height_strength,
            chunk, allow_empty, config_name, params_file, workers, scheduler_address):
    """Import material folders (or 2018 strips) SRC... into a store at OUT (the last path).

    Sources may also come from params.yaml's import.sources (with --params): then OUT is the only path.
    """
    from pathlib import Path

    from .importer.job import run_import

    *sources, out = paths
    cfg = build(ImportConfig, config_name, params_file, "import", sources=tuple(sources) or None, layout=layout,
                size=size, normal_convention=normal_convention, category=category, allow_upscale=allow_upscale,
                as_kind=as_kind, input_space=input_space, height_strength=height_strength, chunk=chunk)
    if not cfg.sources and allow_empty:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        click.echo(f"no import sources: {out} not written")
        return
    path, mats = run_import(out, cfg, workers=workers, scheduler_address=scheduler_address)
    for m in mats:
        for w in m.get("warnings", []):
            click.echo(f"warning: {m['name']}: {w}", err=True)
    click.echo(f"wrote {path} ({len(mats)} materials)")
