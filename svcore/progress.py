"""The one progress helper of the project: a tqdm bar on stderr, silent when stderr is not a terminal.

Whether a bar shows is tqdm's own decision (``disable=None``: off when the output is not a TTY, so redirected logs
and CI captures get no carriage-return noise). tqdm's own environment variables (``TQDM_DISABLE=1``,
``TQDM_MININTERVAL=5``, ``TQDM_SMOOTHING`` ...: any ``TQDM_<ARGUMENT>``) are honoured: an argument the user set
that way is not passed here, so tqdm's value wins. Two svgen aliases remain for the switch itself, used when
``TQDM_DISABLE`` is not set: ``SVGEN_NO_PROGRESS=1`` turns every bar off, ``SVGEN_PROGRESS=1`` forces them on (a
log that should show progress anyway).

Off a terminal a long command would otherwise print nothing for hours: callers that pass ``lines=True``
(``svtrain fit``, ``svtrain eval``) then get :class:`LineProgress` instead of a silent bar, which logs one line
(done/total, rate, ETA and the postfix, e.g. the loss) at the first unit, then every ``SVGEN_PROGRESS_EVERY``
seconds (default 30) or ``every`` units, and at the end. The same switches turn it off (``SVGEN_NO_PROGRESS=1``,
``TQDM_DISABLE=1``, ``disable=True``).
"""
from __future__ import annotations

import os
import sys
import time

from tqdm import tqdm

from .errors import ConfigError
from .log import get_logger

#: environment switches: bars off everywhere / bars on even off a terminal (aliases; tqdm's TQDM_DISABLE wins)
NO_PROGRESS_ENV, PROGRESS_ENV = "SVGEN_NO_PROGRESS", "SVGEN_PROGRESS"
#: prefix of tqdm's own settings from the environment (tqdm.utils.envwrap: TQDM_<keyword argument>)
TQDM_ENV_PREFIX = "TQDM_"
#: seconds between progress lines off a terminal (:class:`LineProgress`)
EVERY_ENV, DEFAULT_EVERY_S = "SVGEN_PROGRESS_EVERY", 30.0
#: how a line looks (tqdm's own formatting: the same rate and ETA a bar shows)
LINE_FORMAT = "{desc}: {n_fmt}/{total_fmt} ({percentage:.0f}%) {rate_fmt}, ETA {remaining}{postfix}"

log = get_logger(__name__)


def _on(value: str | None) -> bool:
    """An environment switch's value: set and not 0/false/no."""
    return (value or "").strip().lower() not in ("", "0", "false", "no")


def _set_by_tqdm_env() -> set[str]:
    """The tqdm keyword arguments the environment sets (``TQDM_MININTERVAL`` -> ``mininterval``)."""
    return {k[len(TQDM_ENV_PREFIX):].lower() for k in os.environ if k.startswith(TQDM_ENV_PREFIX)}


def every_seconds() -> float:
    """Seconds between progress lines: ``SVGEN_PROGRESS_EVERY`` (default 30).

    Raises:
        ConfigError: not a number >= 0.
    """
    raw = os.environ.get(EVERY_ENV, "").strip()
    try:
        value = float(raw) if raw else DEFAULT_EVERY_S
    except ValueError:
        value = -1.0
    if not value >= 0:
        raise ConfigError(f"{EVERY_ENV}={raw!r} is not a number of seconds >= 0")
    return value


class LineProgress:
    """Progress as log lines (INFO, logger ``svgen.svcore``), for a stderr that is not a terminal: the subset of
    tqdm's interface the commands use (``update``, ``set_postfix``, ``close``, a context manager).

    Args:
        total, desc, unit, initial: as :func:`progress`.
        every_s: seconds between lines.
        every: units between lines (None: by time only).
    """

    def __init__(self, total: int, desc: str, unit: str = "it", initial: int = 0, every_s: float = DEFAULT_EVERY_S,
                 every: int | None = None):
        self.total, self.desc, self.unit, self.initial = int(total), desc, unit, int(initial)
        self.n, self.every_s, self.every = int(initial), float(every_s), every
        self.postfix = ""
        self._t0 = self._last_t = time.monotonic()
        self._last_n = None  # no line yet: the first unit gets one (the run is seen to have started)

    def update(self, n: int = 1) -> None:
        self.n += int(n)
        now = time.monotonic()
        if (self._last_n is None or now - self._last_t >= self.every_s
                or (self.every and self.n - self._last_n >= self.every)):
            self._line(now)

    def set_postfix(self, refresh: bool = True, **values) -> None:
        self.postfix = ", ".join(f"{k}={v}" for k, v in values.items())

    def line(self, now: float | None = None) -> str:
        """The current line: done/total, percentage, rate since the start (units of this run), ETA, postfix."""
        elapsed = max(1e-9, (time.monotonic() if now is None else now) - self._t0)
        rate = (self.n - self.initial) / elapsed if self.n > self.initial else None
        return tqdm.format_meter(self.n, self.total, elapsed, prefix=self.desc, unit=self.unit, rate=rate,
                                 postfix=self.postfix or None, bar_format=LINE_FORMAT)

    def _line(self, now: float) -> None:
        log.info("%s", self.line(now))
        self._last_t, self._last_n = now, self.n

    def close(self) -> None:
        if self._last_n != self.n and self.n > self.initial:
            self._line(time.monotonic())
        self._last_n = self.n

    def __enter__(self) -> "LineProgress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def progress(total: int, desc: str, unit: str = "it", initial: int = 0, disable: bool | None = None,
             lines: bool = False, every: int | None = None) -> tqdm | LineProgress:
    """A progress bar showing ``unit``/s.

    Args:
        total: number of units of work.
        desc: label on the left.
        unit: what one unit is ("view", "variant", "it").
        initial: units already done (resumed runs).
        disable: force off (True) or on (False); None: ``TQDM_DISABLE`` when set, else ``SVGEN_NO_PROGRESS`` /
            ``SVGEN_PROGRESS`` when set, else tqdm's detection (on only when stderr is a terminal).
        lines: where that detection finds no terminal, log progress lines instead (:class:`LineProgress`).
        every: with ``lines``, also a line every this many units.
    """
    from_env = _set_by_tqdm_env()
    if disable is None and "disable" not in from_env:
        if _on(os.environ.get(NO_PROGRESS_ENV)):
            disable = True
        elif _on(os.environ.get(PROGRESS_ENV)):
            disable = False
        elif lines and not getattr(sys.stderr, "isatty", lambda: False)():
            return LineProgress(total, desc, unit, initial, every_seconds(), every)
    # tqdm applies TQDM_* only to arguments not passed: leave out our defaults for what the user set
    style = {k: v for k, v in (("file", sys.stderr), ("dynamic_ncols", True), ("smoothing", 0.1))
             if k not in from_env}
    if disable is not None or "disable" not in from_env:
        style["disable"] = disable
    return tqdm(total=total, desc=desc, unit=unit, initial=initial, **style)
