"""The command a store records as CF ``history``: what the user ran, normalised so that it names no time and no place.

A store writer records :func:`history_line` when it creates the store, and :func:`appended` adds it when a command
resumes the store (CF conventions: "a list of the applications that have modified the original data", newest
last). The line is the running click command (``svgen render ...``) rebuilt from what click parsed, so that the
bytes of a store are a function of the seed, the code, the configuration and the inputs, and of nothing else:

- no time (CF recommends one per line, but a time would make two runs of one command write different bytes, and
  DVC hash them apart: a fresh clone's ``dvc repro`` would leave ``dvc.lock`` changed);
- paths as the store records its inputs (``storage.local.recorded_path``: relative to the directory that holds
  the store, whatever the working directory and spelling), the store itself as :data:`OUT`. A path is the value of
  a ``click.Path`` parameter (a config key's flag is one when its command names the key in
  ``config_command(paths=...)``); a path inside a ``--set`` value is kept as typed;
- only the options given on the command line, in the command's own order, each with its parsed value
  (``--res=16`` and ``--res 16`` are one line), and none that changes how a command runs but never what it writes
  (:class:`RuntimeOption`: worker counts, a scheduler address; ``--storage-option``, which may hold credentials,
  is never exposed to the command); user-info in a URL (``s3://KEY:SECRET@bucket``) is dropped;
- a resume by the same command adds no line (a run killed and rerun writes what an uninterrupted one does); another
  command line that resumes the store (other flags for the same configuration) adds its own.

Two spellings of one configuration (``--params`` against the same values as flags) are two commands, so they
record different lines. Through svgen's Python API (no click command runs) the line says so.
"""
from __future__ import annotations

import re
import shlex
from typing import Callable

import click
from click.core import ParameterSource

#: how the history names the store being written (what the card's reconstructed commands call it too)
OUT = "OUT"
#: the line of a store written through svgen's Python API rather than a command
API = "(svgen's Python API)"
_USERINFO = re.compile(r"^([a-zA-Z][a-zA-Z0-9+.-]*://)[^/@]*@")


class RuntimeOption(click.Option):
    """A click option that changes how a command runs, never what it writes (worker counts, a scheduler): the
    history leaves it out, so the bytes of a store do not depend on it. Declare it with ``cls=RuntimeOption``."""


def history_line(recorded: Callable[[str], str]) -> str:
    """One line of CF ``history``: the running click command, normalised (see the module), as
    ``prog sub ARGUMENTS... --option VALUE...``.

    Args:
        recorded: how the store records a path given to a ``click.Path`` parameter (relative to the store's
            directory; :data:`OUT` for the store itself).

    Returns:
        One shell-quoted line, or :data:`API` when no click command is running.
    """
    ctx = click.get_current_context(silent=True)
    if ctx is None:
        return API
    names = []
    c = ctx
    while c is not None:
        names.insert(0, c.info_name)
        c = c.parent
    arguments, options = [], []
    for p in ctx.command.params:
        if isinstance(p, RuntimeOption) or p.name not in ctx.params \
                or ctx.get_parameter_source(p.name) is not ParameterSource.COMMANDLINE:
            continue
        words = _words(p, ctx.params[p.name], recorded)
        (options if isinstance(p, click.Option) else arguments).extend(words)
    return shlex.join([*names, *arguments, *options])


def _words(p: click.Parameter, value, recorded: Callable[[str], str]) -> list[str]:
    """The command-line words of parameter ``p`` with its parsed ``value`` (a tuple when repeatable)."""
    def text(v) -> str:
        v = _USERINFO.sub(r"\1", str(v))
        return recorded(v) if isinstance(p.type, click.Path) else v

    if isinstance(p, click.Argument):
        return [text(v) for v in (value if isinstance(value, tuple) else (value,))]
    if p.is_flag:  # --on/--off pairs name the off side; a flag with a flag_value is on when it holds that value
        on = value if p.is_bool_flag else value == p.flag_value
        return [p.opts[0]] if on else p.secondary_opts[:1]
    values = value if p.multiple else (value,)
    return [w for v in values for w in (p.opts[0], *(text(x) for x in (v if p.nargs > 1 else (v,))))]


def appended(history: str | None, line: str) -> str:
    """``history`` with ``line`` added, unless it is already the last line (a resume by the same command)."""
    if not history:
        return line
    return history if history.split("\n")[-1] == line else f"{history}\n{line}"
