"""The command line a store records as CF ``history``: what the user typed, minus what must not be kept.

:func:`svcore.cli.run_cli` records the command being run (:func:`set_command`); a store writer appends one line,
``<UTC ISO time> <command>``, to the store's ``history`` attribute when it creates the store and each time a
command resumes it (CF conventions: "a list of the applications that have modified the original data", newest
last). ``--storage-option`` values (s3fs credentials, endpoints) are dropped, and so is the user-info part of a
URL (``s3://KEY:SECRET@bucket``).

``history`` is the one attribute of a store that is not a pure function of (seed, configuration, code): it names
when and how the store was made, so two stores made by the same configuration differ in it and in the card's
"How it was made" lines that print it, and in nothing else (tests compare stores through
``tests/conftest.py``'s ``tree_digest``, which leaves out exactly these).
"""
from __future__ import annotations

import datetime as _dt
import re
import shlex

#: the options whose values are never recorded (s3fs options: credentials, endpoints)
SECRET_OPTIONS = ("--storage-option",)
_USERINFO = re.compile(r"^([a-zA-Z][a-zA-Z0-9+.-]*://)[^/@]*@")
_command: list[str] | None = None


def set_command(prog: str, args) -> None:
    """Record the command being run (``prog`` and its arguments as given)."""
    global _command
    _command = [prog, *(str(a) for a in args)]


def clean_args(args: list[str]) -> list[str]:
    """``args`` without :data:`SECRET_OPTIONS` (and their values) and without user-info in URLs."""
    out, skip = [], False
    for a in args:
        if skip:
            skip = False
            continue
        if a in SECRET_OPTIONS:
            skip = True
            continue
        if any(a.startswith(o + "=") for o in SECRET_OPTIONS):
            continue
        out.append(_USERINFO.sub(r"\1", a))
    return out


def command_line() -> str:
    """The recorded command, cleaned and shell-quoted; a note when svgen runs through its Python API."""
    if _command is None:
        return "(svgen's Python API)"
    return shlex.join(clean_args(_command))


def history_line(now: _dt.datetime | None = None) -> str:
    """``<UTC ISO time, seconds> <command>``: one line of CF ``history``."""
    now = now or _dt.datetime.now(_dt.timezone.utc)
    return f"{now.strftime('%Y-%m-%dT%H:%M:%SZ')} {command_line()}"


def appended(history: str | None, line: str | None = None) -> str:
    """``history`` with one more line (the current command's unless ``line``)."""
    line = line or history_line()
    return f"{history}\n{line}" if history else line
