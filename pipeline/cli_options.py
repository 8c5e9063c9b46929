"""Options shared by the stage commands (kept in one place so every stage spells them the same)."""
from __future__ import annotations

import os

import click

from storage.options import storage_option
from svcore.history import RuntimeOption

#: the environment variable read when ``--workers`` is not given. A machine setting, not a parameter: the bytes
#: of a store do not depend on it (tests/test_render_store.py), so it stays out of params.yaml and of dvc.yaml's
#: commands, and changing it reruns no DVC stage (README "DVC").
WORKERS_ENV = "SVGEN_WORKERS"


def parallel_options(f):
    """--workers (or SVGEN_WORKERS) / --scheduler-address (and --storage-option: every stage command takes store arguments).
    They change how a stage runs, never a byte it writes: a store's history leaves them out (RuntimeOption)."""
    f = storage_option(f)
    f = click.option("--scheduler-address", cls=RuntimeOption, default=None, metavar="ADDR",
                     help="A running dask.distributed scheduler (tcp://host:port); default: DASK_SCHEDULER_ADDRESS, "
                          "else local worker processes.")(f)
    f = click.option("--workers", cls=RuntimeOption, type=click.IntRange(min=0), default=min(2, os.cpu_count() or 1),
                     show_default=True, envvar=WORKERS_ENV, show_envvar=True,
                     help=f"Local dask worker processes (0: run in this process, no dask); without the flag, "
                          f"{WORKERS_ENV} when set.")(f)
    return f
