"""The ``svtrain`` command line: ``fit``, ``eval``, ``predict``. Thin wrappers over the modules;
user errors print one line through :func:`pipeline.cli.run_cli`."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from pipeline.cli import run_cli
from pipeline.log import configure, get_logger

log = get_logger(__name__)

DEFAULT_RUN = "runs/train"


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("-v", "--verbose", is_flag=True, help="Debug logging.")
def svtrain(verbose: bool) -> None:
    """svtrain: train and use the single-image SVBRDF capture network."""
    configure(verbose)


@svtrain.command()
@click.option("--preset", default=None, help="Named config preset: compact (default) or paper.")
@click.option("--params", "params_file", type=click.Path(dir_okay=False), default=None,
              help="params.yaml whose 'train' section sets the config (flags override it).")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
              help="Override any config field, e.g. --set model.base_width=32 (repeatable).")
@click.option("--store", default=None, help="Renders store (default: the in-memory synthetic source).")
@click.option("--iterations", type=int, default=None, help="Total optimisation steps.")
@click.option("--batch-size", type=int, default=None, help="Samples per step.")
@click.option("--seed", type=int, default=None, help="Master seed.")
@click.option("--workers", type=int, default=None, help="DataLoader worker processes.")
@click.option("--out", default=DEFAULT_RUN, show_default=True, help="Run directory.")
@click.option("--no-resume", is_flag=True, help="Start over even if the run directory has a checkpoint.")
@click.option("--no-compile", is_flag=True, help="Do not torch.compile the loss renderer.")
def fit(preset, params_file, overrides, store, iterations, batch_size, seed, workers, out, no_resume, no_compile):
    """Train the network (resumes from OUT/checkpoint.pt after an interruption)."""
    from .config import parse_overrides, resolve
    from .fit import fit as run_fit

    ov = parse_overrides(list(overrides))
    for key, val in (("data.store", store), ("optim.iterations", iterations), ("optim.batch_size", batch_size),
                     ("optim.seed", seed), ("data.workers", workers)):
        if val is not None:
            ov[key] = val
    if no_compile:
        ov["optim.compile_loss"] = False
    cfg = resolve(preset, params_file, ov)
    metrics = run_fit(cfg, out, resume=not no_resume)
    click.echo(json.dumps(metrics))


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
