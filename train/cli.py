"""The ``svtrain`` command line: ``fit``, ``eval``, ``eval-extra``, ``eval-reference``, ``predict``,
``export-model``, ``bundle``. Thin: each command lives in its own ``train/commands/<name>.py`` module, loaded lazily,
so ``svtrain --help`` does not import torch; user errors print one line through :func:`svcore.cli.run_cli`."""
from __future__ import annotations

import sys

import click

from svcore.cli import LazyGroup, run_cli, version_option
from svcore.log import configure

#: command name -> "module:attribute" (add a line to add a command); in the order help lists them.
COMMANDS: dict[str, str] = {
    "bundle": "train.commands.bundle:bundle",
    "eval": "train.commands.eval:eval_",
    "eval-extra": "train.commands.eval_extra:eval_extra",
    "eval-reference": "train.commands.eval_reference:eval_reference",
    "export-model": "train.commands.export_model:export_model",
    "fit": "train.commands.fit:fit",
    "predict": "train.commands.predict:predict",
}


@click.group(cls=LazyGroup, registry=COMMANDS, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("-v", "--verbose", is_flag=True, help="Debug logging.")
@version_option("svtrain")
def svtrain(verbose: bool) -> None:
    """svtrain: train and use the single-image SVBRDF capture network."""
    configure(verbose)


def main(argv=None) -> None:
    sys.exit(run_cli(svtrain, "svtrain", argv))


if __name__ == "__main__":
    main()
