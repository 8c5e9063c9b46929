"""`svgen render INPUT... OUT`: flash photographs of every SVBRDF -> renders store."""
from __future__ import annotations

import click

from .cli_options import config_options, parallel_options


@click.command()
@click.argument("inputs", nargs=-1, required=True, type=click.Path())
@click.argument("out", type=click.Path())
@click.option("--views", type=int, default=None, help="Views per SVBRDF [default: 10].")
@click.option("--res", type=int, default=None, help="Render resolution, 16..2048 [default: 256; the paper: 288].")
@click.option("--spp", type=int, default=None, help="Samples per pixel [default: 1].")
@click.option("--light", type=click.Choice(["point", "sphere"]), default=None, help="Flash model [default: point].")
@click.option("--sampler", type=click.Choice(["centre", "stratified", "independent"]), default=None,
              help="Pixel sampling [default: centre].")
@click.option("--seed", type=int, default=None, help="Master seed of the stage [default: 0].")
@click.option("--chunk", type=int, default=None, help="SVBRDFs per zarr chunk [default: 2].")
@config_options("render")
@parallel_options
def render(inputs, out, views, res, spp, light, sampler, seed, chunk, config_name, params_file, workers,
           scheduler_address):
    """Render every SVBRDF of the variants/blends/stress store(s) INPUTS into one renders store at OUT."""
    from .config import build
    from .render.stage import RenderConfig, run_render

    cfg = build(RenderConfig, config_name, params_file, "render", views=views, res=res, spp=spp, light=light,
                sampler=sampler, seed=seed, chunk=chunk)
    path = run_render(inputs, out, cfg, workers=workers, scheduler_address=scheduler_address)
    click.echo(f"wrote {path}")
