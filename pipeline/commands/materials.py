"""``svgen materials``: list the material catalogue, write its docs and a contact sheet."""
from __future__ import annotations

from pathlib import Path

import click

from svcore.cli import force_option
from svcore.outputs import refuse_existing


def _check_out(path: str | None, force: bool) -> Path | None:
    if path is None:
        return None
    refuse_existing([path], force)  # the one overwrite rule (svcore.outputs)
    return Path(path)


@click.command("materials")
@click.option("--class", "cls", default=None, help="Only this material class (e.g. metal).")
@click.option("--sheet", default=None, type=click.Path(dir_okay=False), help="Write a contact sheet PNG here.")
@click.option("--docs", default=None, type=click.Path(dir_okay=False), help="Write markdown docs here.")
@click.option("--tile", default=80, show_default=True, type=click.IntRange(32, 256), help="Sheet tile size (px).")
@click.option("--seed", default=0, show_default=True, type=int, help="Generation seed of the sheet.")
@force_option("--sheet/--docs files")
@click.option("--quiet", "-q", is_flag=True, help="Do not print the catalogue.")
def materials(cls, sheet, docs, tile, seed, force, quiet):
    """List the catalogue: class, preset, parameter, default and range of every exposed parameter."""
    from materials.catalog import contact_sheet, rows, stats, write_docs
    from materials.registry import presets

    sheet_p, docs_p = _check_out(sheet, force), _check_out(docs, force)
    presets(cls)  # UnknownMaterial for a bad --class, before any work
    if not quiet:
        click.echo(f"{'class':<14} {'preset':<32} {'parameter':<16} {'default':>9}  range")
        for c, p, q, d, lo, hi in rows(cls):
            click.echo(f"{c:<14} {p:<32} {q:<16} {d:>9.4g}  [{lo:.4g}, {hi:.4g}]")
        s = stats()
        click.echo(f"# {s['classes']} classes, {s['base_materials']} presets, {s['mean_params']:.1f} parameters "
                   f"per preset on average ({s['min_params']}-{s['max_params']})")
    if docs_p:
        write_docs(docs_p, cls)
        click.echo(f"wrote {docs_p}", err=True)
    if sheet_p:
        contact_sheet(sheet_p, tile=tile, seed=seed, cls=cls)
        click.echo(f"wrote {sheet_p}", err=True)
