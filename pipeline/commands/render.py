"""`svgen render INPUT... OUT`: flash photographs of every SVBRDF -> renders store."""
from __future__ import annotations

import click

from svcore.cli import config_command, require

from ..cli_options import parallel_options
from ..config import RenderConfig


@config_command(RenderConfig, {"views": "--views", "res": "--res", "spp": "--spp", "light": "--light",
                               "sampler": "--sampler", "seed": "--seed", "chunk": "--chunk", "variant": "--variant",
                               "views_per_launch": "--views-per-launch"})
@click.argument("paths", nargs=-1, type=click.Path(), metavar="INPUT... OUT")
@parallel_options
def render(paths, cfg, workers, scheduler_address):
    """Render every SVBRDF of the variants/blends/stress store(s) INPUT into one renders store at OUT."""
    from ..render.stage import run_render

    require(input=paths[:-1], out=paths[-1:] or None)
    path = run_render(paths[:-1], paths[-1], cfg, workers=workers, scheduler_address=scheduler_address)
    click.echo(f"wrote {path}")
