"""`svgen gallery STORE... --out DIR [--reference REF]`: a static HTML page of the stores' SVBRDFs."""
from __future__ import annotations

import click

from storage.options import storage_option


@click.command()
@storage_option
@click.argument("stores", nargs=-1, required=True, type=click.Path())
@click.option("--out", required=True, type=click.Path(file_okay=False),
              help="Folder to create: index.html, gallery.json and thumbs/ (refused if it exists, see --force).")
@click.option("--reference", "references", multiple=True, type=click.Path(), metavar="REF",
              help="A reference store (e.g. `svgen import` of real materials), shown beside the others; repeatable.")
@click.option("--max", "max_n", type=click.IntRange(min=1), default=200, show_default=True,
              help="At most N SVBRDFs per store; a larger store is shown as a seeded sample of N.")
@click.option("--seed", type=click.IntRange(min=0, max=2**64 - 1), default=0, show_default=True,
              help="Seed of that sample (the indices are listed on the page and in gallery.json).")
@click.option("--views", type=click.IntRange(min=1, max=4), default=3, show_default=True,
              help="Views per SVBRDF of a renders store.")
@click.option("--thumb", type=click.IntRange(min=16, max=512), default=64, show_default=True,
              help="Thumbnail side in pixels.")
@click.option("--force", is_flag=True, help="Replace an existing gallery at --out (never a folder that is not one).")
def gallery(stores, out, references, max_n, seed, views, thumb, force):
    """A self-contained HTML page of the SVBRDFs of STORES (maps, views, what made them), filterable by class."""
    from ..gallery import gallery as write_gallery

    path = write_gallery(list(stores), out, list(references), max_n, seed, views, thumb, force)
    click.echo(f"wrote {path}")
