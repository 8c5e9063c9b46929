"""The one overwrite rule of the command lines: an existing output is refused unless ``--force`` is given.

A store, an export folder, a figure or a folder of predicted maps that already exists may be the result of hours
of work or another run's: writing over it is asked for explicitly (``--force``, :func:`svcore.cli.force_option`),
never done in silence. An empty folder holds nothing to lose and is not an existing output.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable

from .errors import SvgenError

#: the flag that allows overwriting, on every command that writes files
FORCE_FLAG = "--force"


class OutputExists(SvgenError):
    """An output path that already holds something, without ``--force``."""


def holds_something(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a file or a non-empty folder (an empty folder or a missing path holds nothing)."""
    p = Path(path)
    if p.is_dir():
        return any(p.iterdir())
    return p.exists() or p.is_symlink()


def refuse_existing(paths: Iterable[str | os.PathLike], force: bool) -> None:
    """Refuse, before any work, outputs that already hold something, unless ``force``.

    Raises:
        OutputExists: one line naming the first existing output (and how many more there are) and ``--force``.
    """
    if force:
        return
    existing = [Path(p) for p in paths if holds_something(p)]
    if existing:
        more = f" (and {len(existing) - 1} more)" if len(existing) > 1 else ""
        raise OutputExists(f"output {existing[0]} already exists{more}; pass {FORCE_FLAG} to overwrite it, or choose "
                           "another path")
