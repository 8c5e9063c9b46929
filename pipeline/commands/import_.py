"""`svgen import SRC... OUT`: material folders, parquet shards (MatSynth) or the 2018 strips -> a variants store (or
a renders store)."""
from __future__ import annotations

import click

from svcore.cli import config_command, require

from ..cli_options import parallel_options
from ..config import ImportConfig


@config_command(ImportConfig, {"layout": "--layout", "size": "--size", "normal_convention": "--normal-convention",
                               "category": "--category", "allow_upscale": "--allow-upscale/--no-allow-upscale",
                               "as_kind": "--as", "input_space": "--input-space",
                               "height_strength": "--height-strength", "crop": "--crop",
                               "capture_cm": "--capture-cm", "chunk": "--chunk", "split": "--split",
                               "only_category": "--only-category", "limit": "--limit",
                               "physical_size_unit": "--physical-size-unit"}, name="import")
@click.argument("paths", nargs=-1, type=click.Path())
@click.option("--allow-empty", is_flag=True,
              help="With no sources (an empty import.sources in params.yaml): write nothing and succeed (DVC).")
@parallel_options
def import_(paths, cfg, allow_empty, workers, scheduler_address):
    """Import material folders, parquet shards (MatSynth; files or folders of them) or 2018 strips SRC... into a
    store at OUT (the last path).

    Sources may also come from params.yaml's import.sources (with --params): then OUT is the only path. Parquet rows
    with a missing map or a bad image are skipped and listed at the end, one line each.
    """
    from pathlib import Path

    from svcore.config import validate

    from ..importer.job import run_import

    require(out=paths)
    *sources, out = paths
    if sources:  # the SRC arguments replace import.sources
        preset = cfg.preset
        cfg = validate(ImportConfig, {**cfg.as_dict(), "sources": sources})
        cfg._preset = preset
    if not cfg.sources and allow_empty:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        click.echo(f"no import sources: {out} not written")
        return
    path, mats = run_import(out, cfg, workers=workers, scheduler_address=scheduler_address)
    for m in mats:
        for w in m.get("warnings", []):
            click.echo(f"warning: {m['name']}: {w}", err=True)
    skipped = _skipped(path)
    for x in skipped:  # the store records them (attrs.import.skipped): a resumed run reports them too
        click.echo(x.line(), err=True)
    click.echo(f"wrote {path} ({len(mats)} materials" + (f"; {len(skipped)} skipped, listed above" if skipped else "")
               + ")")


def _skipped(path: str) -> list:
    """The items an import left out, as its store records them."""
    from storage.store import open_store

    from ..importer.parquet import Skipped

    recorded = open_store(path, ("variants", "renders")).attrs.get("import", {}).get("skipped", [])
    return [Skipped(**x) for x in recorded]
