"""`svgen stats STORE...`: map distributions of stores side by side (table, JSON, chart)."""
from __future__ import annotations

import click

from ..cli_options import storage_option


@click.command()
@storage_option
@click.argument("stores", nargs=-1, required=True, type=click.Path())
@click.option("--out", type=click.Path(file_okay=False), default=None,
              help="Folder for stats.json, stats.md and stats.png [default: print the table only].")
@click.option("--limit", type=click.IntRange(min=1), default=None, help="At most N materials per store, evenly spaced.")
@click.option("--stride", type=click.IntRange(min=1), default=4, show_default=True, help="Use every N-th pixel.")
def stats(stores, out, limit, stride):
    """Distributions of every map over one or more STORES, side by side."""
    import json
    from pathlib import Path

    from ..stats import chart, store_stats, table

    results = [store_stats(s, limit, stride) for s in stores]
    md = table(results)
    click.echo(md)
    if out:
        d = Path(out)
        d.mkdir(parents=True, exist_ok=True)
        (d / "stats.json").write_text(json.dumps(results, indent=1))
        (d / "stats.md").write_text(md + "\n")
        chart(results, d / "stats.png")
        click.echo(f"wrote {d / 'stats.json'}, {d / 'stats.md'}, {d / 'stats.png'}")
