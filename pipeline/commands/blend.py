"""`svgen blend VARIANTS OUT`: alpha-blends of random pairs of variants -> blends store."""
from __future__ import annotations

import click

from svcore.cli import config_command, require

from ..cli_options import parallel_options
from ..config import BlendConfig


@config_command(BlendConfig, {"count": "--count", "seed": "--seed", "alpha_low": "--alpha-low",
                              "alpha_high": "--alpha-high", "mode": "--mode", "mask_per_map": "--mask-per-map/--same-mask",
                              "mask_scale": "--mask-scale", "maps": "--maps", "chunk": "--chunk"})
@click.argument("variants", type=click.Path(), required=False)
@click.argument("out", type=click.Path(), required=False)
@parallel_options
def blend(variants, out, cfg, workers, scheduler_address):
    """Blend random pairs of the VARIANTS store into a blends store at OUT."""
    from ..blend import run_blend

    require(variants=variants, out=out)
    path = run_blend(variants, out, cfg, workers=workers, scheduler_address=scheduler_address)
    click.echo(f"wrote {path}")
