"""The ``svtrain`` commands, one thin click wrapper per module (``train/cli.py``'s ``COMMANDS`` names them), and what
they share: the default run directory and the closing line that says where the outputs went."""
from __future__ import annotations

import click

#: the run directory of ``svtrain fit --out`` and of ``--checkpoint`` in the commands that read a run
DEFAULT_RUN = "runs/train"


def wrote(where, what: str) -> None:
    """The last line of a command whose stdout is data (fit's JSON, eval's table): where its outputs are, on stderr
    so that ``svtrain fit > metrics.json`` stays one JSON document."""
    click.echo(f"wrote {where} ({what})", err=True)
