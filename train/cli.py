"""The ``svtrain`` command line: ``fit``, ``eval``, ``predict``. Thin wrappers over the modules;
user errors print one line through :func:`svcore.cli.run_cli`."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from svcore.cli import config_command, run_cli, version_option
from svcore.log import configure, get_logger

from .config import Config

log = get_logger(__name__)

DEFAULT_RUN = "runs/train"


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("-v", "--verbose", is_flag=True, help="Debug logging.")
@version_option("svtrain")
def svtrain(verbose: bool) -> None:
    """svtrain: train and use the single-image SVBRDF capture network."""
    configure(verbose)


@config_command(Config, {"data.store": "--store", "optim.iterations": "--iterations",
                         "optim.batch_size": "--batch-size", "optim.seed": "--seed", "data.workers": "--workers",
                         "optim.compile_loss": "--compile/--no-compile"})
@click.option("--out", default=DEFAULT_RUN, show_default=True, help="Run directory.")
@click.option("--no-resume", is_flag=True, help="Start over even if the run directory has a checkpoint.")
def fit(cfg, out, no_resume):
    """Train the network (resumes from OUT/checkpoint.pt after an interruption)."""
    from .fit import fit as run_fit

    metrics = run_fit(cfg, out, resume=not no_resume)
    click.echo(json.dumps(metrics))


svtrain.add_command(fit)


@svtrain.command("eval")
@click.option("--checkpoint", "ckpt", default=DEFAULT_RUN, show_default=True, help="Run directory or checkpoint file.")
@click.option("--suite", default="heldout", show_default=True, help="Evaluation suite: heldout (held-out presets), stress (per category of a `svgen stress` renders store given by --store) or all (every view of --store, e.g. imported 2018 strips).")
@click.option("--store", default=None, help="Evaluate on this renders store instead of the training one.")
@click.option("--limit", type=int, default=None, help="Evaluate at most this many samples.")
@click.option("--out", default=None, help="Output directory (default: the run directory).")
def eval_(ckpt, suite, store, limit, out):
    """RMSE per map and of re-renderings, beside the baselines (eval.json, eval.md)."""
    from .evaluate import markdown, run_eval

    out = out or (ckpt if Path(ckpt).is_dir() else str(Path(ckpt).parent))
    res = run_eval(ckpt, out, suite=suite, store=store, limit=limit)
    click.echo(markdown(res), nl=False)


@svtrain.command()
@click.argument("photo", type=click.Path(dir_okay=False))
@click.option("--checkpoint", "ckpt", default=DEFAULT_RUN, show_default=True, help="Run directory or checkpoint file.")
@click.option("--out", default=None, help="Output directory (default: <photo name>_maps beside the photo).")
def predict(photo, ckpt, out):
    """Estimate normal, diffuse, roughness and specular maps from one flash PHOTO (PNG/JPEG sRGB, EXR linear)."""
    from .predict import predict as run_predict

    out = out or str(Path(photo).with_name(Path(photo).stem + "_maps"))
    for p in run_predict(photo, ckpt, out):
        click.echo(str(p))


def main(argv=None) -> None:
    sys.exit(run_cli(svtrain, "svtrain", argv))


if __name__ == "__main__":
    main()
