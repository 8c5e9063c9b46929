"""`svgen export RENDERS OUT --format deschaintre|exr|png`."""
from __future__ import annotations

import click

from svcore.cli import force_option

from ..cli_options import storage_option


@click.command()
@storage_option
@click.argument("renders", type=click.Path())
@click.argument("out", type=click.Path())
@click.option("--format", "fmt", type=click.Choice(["deschaintre", "exr", "png"]), default="deschaintre",
              show_default=True, help="deschaintre: the 2018 dataset layout; exr: linear maps; png: previews.")
@click.option("--limit", type=click.IntRange(min=1), default=None, help="Only the first N views.")
@force_option("exports (only a folder an export wrote is replaced, once the new one is complete)")
def export(renders, out, fmt, limit, force):
    """Write the views of a RENDERS store to files under OUT (refused if OUT holds files, see --force)."""
    from ..export import export as run_export

    n = run_export(renders, out, fmt, limit, force)
    click.echo(f"wrote {n} views to {out}")
