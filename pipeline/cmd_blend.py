"""`svgen blend VARIANTS OUT`: alpha-blends of random pairs of variants -> blends store."""
from __future__ import annotations

import click

from .cli_options import config_options, parallel_options
from .config import BlendConfig, build


@click.command()
@click.argument("variants", type=click.Path())
@click.argument("out", type=click.Path())
@click.option("--count", type=int, default=None, help="Number of blends [default: 120].")
@click.option("--seed", type=int, default=None, help="Master seed of the stage [default: 0].")
@click.option("--alpha-low", type=float, default=None, help="alpha ~ U(low, high) [default: 0.2].")
@click.option("--alpha-high", type=float, default=None, help="[default: 0.8].")
@click.option("--mode", type=click.Choice(["scalar", "mask"]), default=None,
              help="scalar: one alpha (the paper) [default]; mask: a procedural mask with mean alpha.")
@click.option("--mask-per-map/--same-mask", default=None, help="Mask mode: a different mask per map.")
@click.option("--mask-scale", type=float, default=None, help="Mask mode: patches per tile [default: 4].")
@click.option("--chunk", type=int, default=None, help="Samples per zarr chunk [default: 8].")
@config_options("blend")
@parallel_options
def blend(variants, out, count, seed, alpha_low, alpha_high, mode, mask_per_map, mask_scale, chunk, config_name,
          params_file, workers, scheduler_address):
    """Blend random pairs of the VARIANTS store into a blends store at OUT."""
    from .blend import run_blend

    cfg = build(BlendConfig, config_name, params_file, "blend", count=count, seed=seed, alpha_low=alpha_low,
                alpha_high=alpha_high, mode=mode, mask_per_map=mask_per_map, mask_scale=mask_scale, chunk=chunk)
    path = run_blend(variants, out, cfg, workers=workers, scheduler_address=scheduler_address)
    click.echo(f"wrote {path}")
