"""Options shared by the stage commands (kept in one place so every stage spells them the same)."""
from __future__ import annotations

import os

import click


def parallel_options(f):
    """--workers / --scheduler-address."""
    f = click.option("--scheduler-address", default=None, metavar="ADDR",
                     help="A running dask.distributed scheduler (tcp://host:port); default: DASK_SCHEDULER_ADDRESS, "
                          "else local worker processes.")(f)
    f = click.option("--workers", type=click.IntRange(min=0), default=min(2, os.cpu_count() or 1), show_default=True,
                     help="Local dask worker processes (0: run in this process, no dask).")(f)
    return f
