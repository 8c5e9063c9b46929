"""The one progress helper of the project: a tqdm bar on stderr, silent when stderr is not a terminal.

Whether a bar shows is tqdm's own decision (``disable=None``: off when the output is not a TTY, so redirected logs
and CI captures get no carriage-return noise). tqdm's own environment variables (``TQDM_DISABLE=1``,
``TQDM_MININTERVAL=5``, ``TQDM_SMOOTHING`` ...: any ``TQDM_<ARGUMENT>``) are honoured: an argument the user set
that way is not passed here, so tqdm's value wins. Two svgen aliases remain for the switch itself, used when
``TQDM_DISABLE`` is not set: ``SVGEN_NO_PROGRESS=1`` turns every bar off, ``SVGEN_PROGRESS=1`` forces them on (a
log that should show progress anyway).
"""
from __future__ import annotations

import os
import sys

from tqdm import tqdm

#: environment switches: bars off everywhere / bars on even off a terminal (aliases; tqdm's TQDM_DISABLE wins)
NO_PROGRESS_ENV, PROGRESS_ENV = "SVGEN_NO_PROGRESS", "SVGEN_PROGRESS"
#: prefix of tqdm's own settings from the environment (tqdm.utils.envwrap: TQDM_<keyword argument>)
TQDM_ENV_PREFIX = "TQDM_"


def _on(value: str | None) -> bool:
    """An environment switch's value: set and not 0/false/no."""
    return (value or "").strip().lower() not in ("", "0", "false", "no")


def _set_by_tqdm_env() -> set[str]:
    """The tqdm keyword arguments the environment sets (``TQDM_MININTERVAL`` -> ``mininterval``)."""
    return {k[len(TQDM_ENV_PREFIX):].lower() for k in os.environ if k.startswith(TQDM_ENV_PREFIX)}


def progress(total: int, desc: str, unit: str = "it", initial: int = 0, disable: bool | None = None) -> tqdm:
    """A progress bar showing ``unit``/s.

    Args:
        total: number of units of work.
        desc: label on the left.
        unit: what one unit is ("view", "variant", "it").
        initial: units already done (resumed runs).
        disable: force off (True) or on (False); None: ``TQDM_DISABLE`` when set, else ``SVGEN_NO_PROGRESS`` /
            ``SVGEN_PROGRESS`` when set, else tqdm's detection (on only when stderr is a terminal).
    """
    from_env = _set_by_tqdm_env()
    if disable is None and "disable" not in from_env:
        if _on(os.environ.get(NO_PROGRESS_ENV)):
            disable = True
        elif _on(os.environ.get(PROGRESS_ENV)):
            disable = False
    # tqdm applies TQDM_* only to arguments not passed: leave out our defaults for what the user set
    style = {k: v for k, v in (("file", sys.stderr), ("dynamic_ncols", True), ("smoothing", 0.1))
             if k not in from_env}
    if disable is not None or "disable" not in from_env:
        style["disable"] = disable
    return tqdm(total=total, desc=desc, unit=unit, initial=initial, **style)
