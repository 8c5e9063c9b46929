"""`svgen stress OUT`: the failure-case evaluation sets (paper §6) as a stress store, to render and evaluate."""
from __future__ import annotations

import click

from svcore.cli import config_command, require

from ..cli_options import parallel_options
from ..config import StressConfig


@config_command(StressConfig, {"per_category": "--per-category", "size": "--size", "seed": "--seed",
                               "categories": "--category", "chunk": "--chunk"})
@click.argument("out", type=click.Path(), required=False)
@parallel_options
def stress(out, cfg, workers, scheduler_address):
    """Write the stress categories (glossy, edge highlight, prints, dark/bright albedo, decorrelated, reference)."""
    from ..stress import run_stress

    require(out=out)
    path = run_stress(out, cfg, workers=workers, scheduler_address=scheduler_address)
    click.echo(f"wrote {path}")
