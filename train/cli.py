"""The ``svtrain`` command line: ``fit``, ``eval``, ``predict``, ``export-model``, ``bundle``. Thin wrappers over
the modules; user errors print one line through :func:`svcore.cli.run_cli`."""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import click

from storage.options import storage_option
from svcore.cli import config_command, force_option, run_cli, version_option
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
                         "optim.compile_loss": "--compile/--no-compile", "compute.device": "--device",
                         "compute.precision": "--precision", "compute.nproc": "--nproc",
                         "compute.global_batch": "--global-batch", "optim.init": "--init"},
                envvars={"data.workers": "SVGEN_WORKERS"})
@click.option("--out", default=DEFAULT_RUN, show_default=True, help="Run directory.")
@storage_option
@click.option("--no-resume", is_flag=True, help="Start over even if the run directory has a checkpoint.")
@click.option("--resume-if-unchanged", is_flag=True,
              help="Continue OUT/checkpoint.pt only if it was trained from this config, data and code; otherwise "
                   "start over (what dvc.yaml's fit stage uses: its checkpoint persists across changed runs).")
def fit(cfg, out, no_resume, resume_if_unchanged):
    """Train the network (resumes from OUT/checkpoint.pt after an interruption)."""
    if no_resume and resume_if_unchanged:
        raise click.UsageError("--no-resume and --resume-if-unchanged contradict each other: pass one")
    from . import distributed
    from .fit import fit as run_fit

    resume = False if no_resume else ("if-unchanged" if resume_if_unchanged else True)
    if distributed.world_from_env().size == 1 and cfg.compute.nproc > 1:
        distributed.launch_checked(cfg, out, resume=resume)
        from . import timing

        clocked = timing.read(out)
        click.echo(json.dumps({**json.loads(Path(out, "metrics.json").read_text()),
                               **{k: clocked.get(k) for k in timing.KEYS}}))
        _wrote(out, "model.pt, metrics.json, loss.png; timing.json: the clock")
        return
    try:
        metrics = run_fit(cfg, out, resume=resume)
    except distributed.SvgenError as e:
        if distributed.report_to_launcher(e):  # svtrain's launcher prints one line for the whole run
            raise click.exceptions.Exit(e.exit_code)
        raise
    except KeyboardInterrupt:
        if os.environ.get(distributed.ERROR_DIR_ENV):  # Ctrl-C reached every worker: the launcher reports it
            raise click.exceptions.Exit(130)
        raise
    if distributed.world_from_env().main and not os.environ.get(distributed.ERROR_DIR_ENV):
        click.echo(json.dumps(metrics))  # (under svtrain's own launcher, the launcher prints it)
        _wrote(out, "model.pt, metrics.json, loss.png; timing.json: the clock")


def _wrote(where, what: str) -> None:
    """The last line of a command whose stdout is data (fit's JSON, eval's table): where its outputs are, on stderr
    so that ``svtrain fit > metrics.json`` stays one JSON document."""
    click.echo(f"wrote {where} ({what})", err=True)


svtrain.add_command(fit)


@svtrain.command("eval")
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
    from .evaluate import markdown, run_eval

    from .bundled_model import is_bundled

    out = out or ("runs/eval_bundled" if is_bundled(ckpt) else ckpt if Path(ckpt).is_dir() else str(Path(ckpt).parent))
    res = run_eval(ckpt, out, suite=suite, store=store, limit=limit, train_store=train_store, device=device)
    click.echo(markdown(res), nl=False)
    _wrote(out, "eval.json, eval.md, eval.png")


@svtrain.command("eval-extra")
@click.option("--checkpoint", "ckpt", default=DEFAULT_RUN, show_default=True, help="Run directory or checkpoint file.")
@click.option("--params", "params_file", default="params.yaml", show_default=True,
              help="The params file whose eval.extra_stores lists the renders stores (eval.limit: views per store).")
@click.option("--out", required=True, help="Output directory: one sub-folder per store, eval_metrics.json.")
@click.option("--device", default="cpu", show_default=True, help="auto, cpu, cuda, cuda:N or mps.")
@storage_option
def eval_extra(ckpt, params_file, out, device):
    """Evaluate on every renders store of params.yaml eval.extra_stores (suite all); nothing when the list is empty."""
    from .eval_extra import run

    table = run(ckpt, params_file, out, device)
    click.echo(json.dumps(table))
    _wrote(out, f"{len(table)} store(s), eval_metrics.json")


@svtrain.command("eval-reference")
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
    from .eval_reference import run, summary

    res = run(ckpt, params_file, store, out, device)
    if res is None:
        click.echo(f"no reference sources ({params_file}: reference.sources is empty): nothing evaluated")
        return
    click.echo(summary(res))
    _wrote(out, "eval/eval.json, eval/eval.md, eval_metrics.json")


@svtrain.command()
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

    from .predict import predict_many

    if ckpt is None:
        from .bundled_model import describe

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


@svtrain.command("export-model")
@click.argument("run")
@click.option("--format", "fmt", type=click.Choice(["onnx"]), default="onnx", show_default=True,
              help="Model format: onnx (torch.onnx, opset 17).")
@click.argument("out", type=click.Path())
@click.option("--size", type=int, default=256, show_default=True,
              help="Square side traced for the export (a multiple of the stride 2^levels); the exported image size "
                   "stays dynamic.")
def export_model(run, fmt, out, size):
    """Export RUN (a run directory, checkpoint file or 'bundled') to OUT for use outside svgen.

    ONNX, opset 17. Input 'image': (B, 3, H, W) float32 linear RGB in [0, 1] (sRGB-decode PNG/JPEG first), H and W
    multiples of the stride 2^levels (128 for the compact preset); batch and size are dynamic. Outputs, decoded:
    'normal' (B,3,H,W) unit xyz, 'diffuse' (B,3,H,W) linear, 'roughness' (B,1,H,W) perceptual, 'specular'
    (B,3,H,W) linear F0. A checkpoint of another svgen version is exported only when its weights load unchanged.
    """
    from .export import export_onnx

    path, note = export_onnx(run, out, size)
    if note:
        click.echo(note, err=True)
    click.echo(str(path))


@svtrain.command()
@click.argument("run")
@click.option("--stress-store", default=None, help="A `svgen stress` renders store: the card's stress table and "
              "known failure cases.")
@click.option("--reference-store", default=None, help="The reference renders store (`svgen reference OUT`: "
              "OUT/renders.zarr): the card's real-material table, when --params lists reference sources.")
@click.option("--params", "params_file", default="params.yaml", show_default=True,
              help="The params file whose reference.sources says whether there is a reference (empty: no table).")
@click.option("--into", default=None, help="Folder to write (default: the package's train/bundled).")
@click.option("--limit", type=int, default=400, show_default=True, help="Held-out views evaluated for the card.")
@click.option("--final", is_flag=True, help="Not a placeholder: drop the card's placeholder notice.")
@click.option("--device", default="cpu", show_default=True, help="auto, cpu, cuda, cuda:N or mps.")
def bundle(run, stress_store, reference_store, params_file, into, limit, final, device):
    """Make RUN the model shipped with svgen: weights-only model.pt, bundled.json and MODEL_CARD.md (evaluated)."""
    from .bundle import bundle as run_bundle

    out = run_bundle(run, stress_store, into, limit, placeholder=not final, device=device,
                     reference_store=reference_store, params_file=params_file)
    _wrote(out, "model.pt, bundled.json, MODEL_CARD.md")


def main(argv=None) -> None:
    sys.exit(run_cli(svtrain, "svtrain", argv))


if __name__ == "__main__":
    main()
