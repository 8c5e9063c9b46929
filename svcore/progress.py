"""The one progress helper of the project: a tqdm bar on stderr, silent when stderr is not a terminal.

Whether a bar shows is tqdm's own decision (``disable=None``: off when the output is not a TTY, so redirected logs
and CI captures get no carriage-return noise), with two switches on top: ``SVGEN_NO_PROGRESS=1`` turns every bar
off, ``SVGEN_PROGRESS=1`` forces them on (a log that should show progress anyway).
"""
from __future__ import annotations

import os
import sys

from tqdm import tqdm

#: environment switches: bars off everywhere / bars on even off a terminal
NO_PROGRESS_ENV, PROGRESS_ENV = "SVGEN_NO_PROGRESS", "SVGEN_PROGRESS"


def _on(value: str | None) -> bool:
    """An environment switch's value: set and not 0/false/no."""
    return (value or "").strip().lower() not in ("", "0", "false", "no")


def progress(total: int, desc: str, unit: str = "it", initial: int = 0, disable: bool | None = None) -> tqdm:
    """A progress bar showing ``unit``/s.

    Args:
        total: number of units of work.
        desc: label on the left.
        unit: what one unit is ("view", "variant", "it").
        initial: units already done (resumed runs).
        disable: force off (True) or on (False); None: ``SVGEN_NO_PROGRESS`` / ``SVGEN_PROGRESS`` when set, else
            tqdm's detection (on only when stderr is a terminal).
    """
    if disable is None:
        if _on(os.environ.get(NO_PROGRESS_ENV)):
            disable = True
        elif _on(os.environ.get(PROGRESS_ENV)):
            disable = False
    return tqdm(total=total, desc=desc, unit=unit, initial=initial, disable=disable, file=sys.stderr,
                dynamic_ncols=True, smoothing=0.1)
