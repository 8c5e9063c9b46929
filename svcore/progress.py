"""The one progress helper of the project (a tqdm bar on stderr, silent when not a TTY unless forced)."""
from __future__ import annotations

import os
import sys

from tqdm.auto import tqdm


def progress(total: int, desc: str, unit: str = "it", initial: int = 0, disable: bool | None = None) -> tqdm:
    """A progress bar showing ``unit``/s.

    Args:
        total: number of units of work.
        desc: label on the left.
        unit: what one unit is ("view", "variant", "it").
        initial: units already done (resumed runs).
        disable: force on/off; default: off when ``SVGEN_NO_PROGRESS`` is set or stderr is not a terminal
            (logs and CI captures get no carriage-return noise), on otherwise; ``SVGEN_PROGRESS=1`` forces it on.
    """
    if disable is None:
        if os.environ.get("SVGEN_NO_PROGRESS"):
            disable = True
        elif os.environ.get("SVGEN_PROGRESS"):
            disable = False
        else:
            disable = not sys.stderr.isatty()
    return tqdm(total=total, desc=desc, unit=unit, initial=initial, disable=disable, file=sys.stderr,
                dynamic_ncols=True, smoothing=0.1)
