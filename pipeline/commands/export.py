"""`svgen export STORE OUT --format deschaintre|exr|png|parquet`."""
from __future__ import annotations

import click

from svcore.cli import force_option

from ..cli_options import storage_option


@click.command()
@storage_option
@click.argument("store", type=click.Path())
@click.argument("out", type=click.Path())
@click.option("--format", "fmt", type=click.Choice(["deschaintre", "exr", "png", "parquet"]), default="deschaintre",
              show_default=True, help="deschaintre: the 2018 dataset layout; exr: linear maps; png: previews; "
              "parquet: shards with `datasets` image columns and a dataset card (renders or variants stores).")
@click.option("--limit", type=click.IntRange(min=1), default=None, help="Only the first N views (rows).")
@force_option("exports (only a folder an export wrote is replaced, once the new one is complete)")
def export(store, out, fmt, limit, force):
    """Write the views of a renders STORE (parquet: or the samples of a variants store) to files under OUT (refused
    if OUT holds files, see --force)."""
    from ..export import export as run_export

    n = run_export(store, out, fmt, limit, force)
    click.echo(f"wrote {n} {'rows' if fmt == 'parquet' else 'views'} to {out}")
