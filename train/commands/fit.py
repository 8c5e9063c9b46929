"""``svtrain fit``: train the network (:mod:`train.fit`) in this process, or through svtrain's own launcher when
``--nproc`` asks for more than one."""
from __future__ import annotations

import json
import os
from pathlib import Path

import click

from storage.options import storage_option
from svcore.cli import config_command

from ..config import Config
from . import DEFAULT_RUN, wrote


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
    from .. import distributed
    from ..fit import fit as run_fit

    resume = False if no_resume else ("if-unchanged" if resume_if_unchanged else True)
    if distributed.world_from_env().size == 1 and cfg.compute.nproc > 1:
        distributed.launch_checked(cfg, out, resume=resume)
        from .. import timing

        clocked = timing.read(out)
        click.echo(json.dumps({**json.loads(Path(out, "metrics.json").read_text()),
                               **{k: clocked.get(k) for k in timing.KEYS}}))
        wrote(out, "model.pt, metrics.json, loss.png; timing.json: the clock")
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
        wrote(out, "model.pt, metrics.json, loss.png; timing.json: the clock")
