"""``svtrain eval-extra``: evaluate on every renders store of params.yaml ``eval.extra_stores``
(:mod:`train.eval_extra`, DVC stage eval_extra)."""
from __future__ import annotations

import json

import click

from storage.options import storage_option

from . import DEFAULT_RUN, wrote


@click.command("eval-extra")
@click.option("--checkpoint", "ckpt", default=DEFAULT_RUN, show_default=True, help="Run directory or checkpoint file.")
@click.option("--params", "params_file", default="params.yaml", show_default=True,
              help="The params file whose eval.extra_stores lists the renders stores (eval.limit: views per store).")
@click.option("--out", required=True, help="Output directory: one sub-folder per store, eval_metrics.json.")
@click.option("--device", default="cpu", show_default=True, help="auto, cpu, cuda, cuda:N or mps.")
@storage_option
def eval_extra(ckpt, params_file, out, device):
    """Evaluate on every renders store of params.yaml eval.extra_stores (suite all); nothing when the list is empty."""
    from ..eval_extra import run

    table = run(ckpt, params_file, out, device)
    click.echo(json.dumps(table))
    wrote(out, f"{len(table)} store(s), eval_metrics.json")
