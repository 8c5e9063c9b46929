"""What both command lines (``svgen``, ``svtrain``) share: the one-line error funnel and ``--version``.

:func:`run_cli` is the only place that turns exceptions into exit codes: user errors (the
:class:`~svcore.errors.SvgenError` family and click's usage errors) print one line and exit 2, environment
errors (full disk, permissions) one line and exit 1, anything else one line naming it as an internal error
(``SVGEN_DEBUG=1`` shows the traceback).
"""
from __future__ import annotations

import errno
import os
import subprocess
from functools import lru_cache
from pathlib import Path

import click

from .errors import SvgenError

_OS_HINTS = {errno.ENOSPC: "free space and rerun: completed chunks are kept and the run resumes",
             errno.EDQUOT: "free quota and rerun: completed chunks are kept and the run resumes",
             errno.EFBIG: "file size limit reached; raise it and rerun",
             errno.EACCES: "check the permissions of the output location"}


def one_line(msg: object) -> str:
    """Messages from libraries can span lines (YAML, zarr, pydantic); the CLI promises one."""
    return " ".join(str(msg).split())


@lru_cache(maxsize=1)
def version() -> str:
    """``git describe`` of the source tree when it is a git checkout, else the installed package version."""
    root = Path(__file__).resolve().parents[1]
    if (root / ".git").exists():
        try:
            r = subprocess.run(["git", "describe", "--tags", "--always", "--dirty"], cwd=root, capture_output=True,
                               text=True, timeout=5)
            if r.returncode == 0 and r.stdout.strip():
                return r.stdout.strip()
        except (OSError, subprocess.SubprocessError):
            pass
    import importlib.metadata as md

    try:
        return md.version("svgen")
    except md.PackageNotFoundError:
        return "unknown"


def version_option(prog: str):
    """``--version``: print ``PROG VERSION`` (see :func:`version`) and exit 0."""

    def show(ctx, _param, value):
        if value and not ctx.resilient_parsing:
            click.echo(f"{prog} {version()}")
            ctx.exit(0)

    return click.option("--version", is_flag=True, expose_value=False, is_eager=True, callback=show,
                        help="Print the version (git describe of the source, else the package version) and exit.")


def run_cli(group: click.Group, prog: str, argv=None) -> int:
    """Run a click group; user errors become one line on stderr and exit code 2 (no traceback).

    Set ``SVGEN_DEBUG=1`` to see tracebacks of unexpected errors.
    """
    try:
        group.main(args=argv, prog_name=prog, standalone_mode=False)
        return 0
    except click.exceptions.Abort:
        click.echo(f"{prog}: aborted", err=True)
        return 130
    except click.exceptions.Exit as e:
        return e.exit_code
    except click.ClickException as e:
        click.echo(f"{prog}: error: {one_line(e.format_message())}", err=True)
        return e.exit_code or 2
    except SvgenError as e:
        click.echo(f"{prog}: error: {one_line(e)}", err=True)
        return getattr(e, "exit_code", 2)
    except KeyboardInterrupt:
        click.echo(f"{prog}: interrupted", err=True)
        return 130
    except OSError as e:  # full disk, quota, permissions: the environment, not a bug
        hint = _OS_HINTS.get(e.errno, "")
        where = f" ({e.filename})" if e.filename else ""
        click.echo(f"{prog}: error: {e.strerror or e}{where}" + (f"; {hint}" if hint else ""), err=True)
        return 1
    except Exception as e:  # an unexpected failure: still one line, traceback on request
        if os.environ.get("SVGEN_DEBUG"):
            raise
        click.echo(f"{prog}: internal error: {type(e).__name__}: {one_line(e)} (set SVGEN_DEBUG=1 for the traceback)",
                   err=True)
        return 1
