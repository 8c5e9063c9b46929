"""``svtrain eval-reference``: evaluate on every view of the reference renders store (:mod:`train.eval_reference`,
DVC stage eval_reference)."""
from __future__ import annotations

import click

from storage.options import storage_option

from . import DEFAULT_RUN, wrote


@click.command("eval-reference")
@click.option("--checkpoint", "ckpt", default=DEFAULT_RUN, show_default=True, help="Run directory or checkpoint file.")
@click.option("--params", "params_file", default="params.yaml", show_default=True,
              help="The params file whose reference.sources says whether there is a reference (empty: nothing).")
@click.option("--store", required=True, help="The reference renders store (`svgen reference OUT`: OUT/renders.zarr).")
@click.option("--out", required=True, help="Output directory: eval/ (eval.json, eval.md ...) and eval_metrics.json.")
@click.option("--device", default="cpu", show_default=True, help="auto, cpu, cuda, cuda:N or mps.")
@storage_option
def eval_reference(ckpt, params_file, store, out, device):
    """Evaluate on every view of the reference renders store (real materials); nothing when reference.sources is
    empty."""
    from ..eval_reference import run, summary

    res = run(ckpt, params_file, store, out, device)
    if res is None:
        click.echo(f"no reference sources ({params_file}: reference.sources is empty): nothing evaluated")
        return
    click.echo(summary(res))
    wrote(out, "eval/eval.json, eval/eval.md, eval_metrics.json")
