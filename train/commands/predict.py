"""``svtrain predict``: maps from flash photos (:mod:`train.predict`), by the bundled model unless a run is named."""
from __future__ import annotations

import click

from svcore.cli import force_option


@click.command()
@click.argument("photos", nargs=-1, required=True, type=click.Path())
@click.option("--checkpoint", "ckpt", default=None,
              help="Run directory, checkpoint file or 'bundled'. Default: the model shipped with svgen (bundled).")
@click.option("--out", default=None, help="Output folder: the maps of a single photo, or one sub-folder per photo "
              "(default: <photo name>_maps beside each photo, <folder>_maps for a folder).")
@click.option("--size", type=click.IntRange(min=1), default=256, show_default=True,
              help="Prediction size: a multiple of the network's stride (2^levels); the paper captures at 256.")
@click.option("--input-space", type=click.Choice(["auto", "srgb", "linear"]), default="auto", show_default=True,
              help="auto: PNG/JPEG are sRGB, EXR linear. The 2018 paper's PNG data are linear: use linear for them.")
@click.option("--batch", "batch_size", type=click.IntRange(min=1), default=8, show_default=True, help="Photos per network call.")
@click.option("--device", default="cpu", show_default=True, help="auto, cpu, cuda, cuda:N or mps.")
@force_option("maps folders")
def predict(photos, ckpt, out, size, input_space, batch_size, device, force):
    """Estimate normal, diffuse, roughness and specular maps from flash PHOTOS (files or folders; PNG/JPEG/EXR)."""
    from svcore.errors import SvgenError

    from ..predict import predict_many

    if ckpt is None:
        from ..bundled_model import describe

        click.echo(describe(), err=True)  # one line: which model runs when none is named
    res = predict_many(list(photos), ckpt, out, size, input_space, batch_size, device, force=force)
    for d in res.written:
        click.echo(str(d))
    if len(res.failed) == 1 and not res.written:
        raise SvgenError(res.failed[0][1])
    if res.failed:
        listed = "; ".join(f"{p.name}: {why}" for p, why in res.failed)
        raise SvgenError(f"{len(res.failed)} of {len(res.failed) + len(res.written)} photo(s) could not be read "
                         f"({len(res.written)} written): {listed}")
