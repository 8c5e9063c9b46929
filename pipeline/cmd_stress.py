"""`svgen stress OUT`: the failure-case evaluation sets (paper §6) as a stress store, to render and evaluate."""
from __future__ import annotations

import click

from .cli_options import parallel_options


@click.command()
@click.argument("out", type=click.Path())
@click.option("--per-category", type=int, default=8, show_default=True, help="SVBRDFs per category.")
@click.option("--size", type=int, default=256, show_default=True, help="Map resolution.")
@click.option("--seed", type=int, default=0, show_default=True, help="Master seed.")
@click.option("--category", "categories", multiple=True, help="Only these categories (repeatable; default all).")
@parallel_options
def stress(out, per_category, size, seed, categories, workers, scheduler_address):
    """Write the stress categories (glossy, edge highlight, prints, dark/bright albedo, decorrelated, reference)."""
    from .stress import run_stress

    path = run_stress(out, per_category, size, seed, categories, workers=workers, scheduler_address=scheduler_address)
    click.echo(f"wrote {path}")
