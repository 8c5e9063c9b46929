"""``svtrain eval``: RMSE per map and of re-renderings beside the baselines (:mod:`train.evaluate`)."""
from __future__ import annotations

from pathlib import Path

import click

from storage.options import storage_option

from . import DEFAULT_RUN, wrote


@click.command("eval")
@click.option("--checkpoint", "ckpt", default=DEFAULT_RUN, show_default=True,
              help="Run directory, checkpoint file, or 'bundled' (the model shipped with svgen).")
@click.option("--suite", default=None, help="Evaluation suite: heldout (held-out presets), train (400 training views spread over the training split: does the model fit what it saw?), stress (per category of a `svgen stress` renders store given by --store) or all (every view of --store, e.g. imported 2018 strips). Default: heldout on the checkpoint's training store, all on any other store (training saw none of it); eval.md says which.")
@click.option("--store", default=None, help="Evaluate on this renders store instead of the training one (in full unless --suite says otherwise).")
@click.option("--limit", type=click.IntRange(min=1), default=None, help="Evaluate at most this many samples.")
@click.option("--out", default=None, help="Output directory (default: the run directory).")
@click.option("--train-store", default=None,
              help="The run's training store, needed only for its held-out split (no --store) when it moved, or "
                   "for a run from before `svtrain fit` recorded the baselines' means (default: found through the "
                   "run's run.json); its means then replace recorded ones.")
@click.option("--device", default="cpu", show_default=True, help="auto, cpu, cuda, cuda:N or mps.")
@storage_option
def eval_(ckpt, suite, store, limit, out, train_store, device):
    """RMSE per map and of re-renderings, beside the baselines (eval.json, eval.md)."""
    from ..evaluate import markdown, run_eval

    from ..bundled_model import is_bundled

    out = out or ("runs/eval_bundled" if is_bundled(ckpt) else ckpt if Path(ckpt).is_dir() else str(Path(ckpt).parent))
    res = run_eval(ckpt, out, suite=suite, store=store, limit=limit, train_store=train_store, device=device)
    click.echo(markdown(res), nl=False)
    wrote(out, "eval.json, eval.md, eval.png")
