"""The ``svgen`` command line. Thin: each command lives in its own ``cmd_*.py`` module, loaded lazily,
so ``svgen --help`` does not import mitsuba or dask."""
from __future__ import annotations

import importlib
import os
import sys

import click

from .log import configure

#: command name -> "module:attribute" (a registry instead of an if-chain; add a line to add a command).
COMMANDS: dict[str, str] = {
    "materials": "pipeline.cmd_materials:materials",
    "sample": "pipeline.cmd_sample:sample",
    "blend": "pipeline.cmd_blend:blend",
    "render": "pipeline.cmd_render:render",
    "export": "pipeline.cmd_export:export",
    "stress": "pipeline.cmd_stress:stress",
    "import": "pipeline.cmd_import:import_",
    "stats": "pipeline.cmd_stats:stats",
}


class LazyGroup(click.Group):
    def list_commands(self, ctx):
        return [name for name in COMMANDS if _importable(name)]

    def get_command(self, ctx, name):
        if name not in COMMANDS:
            return None
        mod, attr = COMMANDS[name].split(":")
        try:
            return getattr(importlib.import_module(mod), attr)
        except ModuleNotFoundError as e:
            if e.name == mod:
                return None
            raise


def _importable(name: str) -> bool:
    mod = COMMANDS[name].split(":")[0]
    return importlib.util.find_spec(mod) is not None


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("-v", "--verbose", is_flag=True, help="Debug logging.")
def cli(verbose: bool) -> None:
    """svgen: procedural SVBRDF training data for single-image material capture."""
    configure(verbose)


def _one_line(msg: object) -> str:
    """Messages from libraries can span lines (YAML, zarr); the CLI promises one."""
    return " ".join(str(msg).split())


def run_cli(group: click.Group, prog: str, argv=None) -> int:
    """Run a click group; user errors become one line on stderr and exit code 2 (no traceback).

    Set ``SVGEN_DEBUG=1`` to see tracebacks of unexpected errors.
    """
    from .errors import user_error_types

    try:
        group.main(args=argv, prog_name=prog, standalone_mode=False)
        return 0
    except click.exceptions.Abort:
        click.echo(f"{prog}: aborted", err=True)
        return 130
    except click.exceptions.Exit as e:
        return e.exit_code
    except click.ClickException as e:
        click.echo(f"{prog}: error: {_one_line(e.format_message())}", err=True)
        return e.exit_code or 2
    except user_error_types() as e:
        click.echo(f"{prog}: error: {_one_line(e)}", err=True)
        return getattr(e, "exit_code", 2)
    except KeyboardInterrupt:
        click.echo(f"{prog}: interrupted", err=True)
        return 130
    except OSError as e:  # full disk, quota, permissions: the environment, not a bug
        import errno

        hint = {errno.ENOSPC: "free space and rerun: completed chunks are kept and the run resumes",
                errno.EDQUOT: "free quota and rerun: completed chunks are kept and the run resumes",
                errno.EFBIG: "file size limit reached; raise it and rerun",
                errno.EACCES: "check the permissions of the output location"}.get(e.errno, "")
        where = f" ({e.filename})" if e.filename else ""
        click.echo(f"{prog}: error: {e.strerror or e}{where}" + (f"; {hint}" if hint else ""), err=True)
        return 1
    except Exception as e:  # an unexpected failure: still one line, traceback on request
        if os.environ.get("SVGEN_DEBUG"):
            raise
        click.echo(f"{prog}: internal error: {type(e).__name__}: {_one_line(e)} (set SVGEN_DEBUG=1 for the traceback)",
                   err=True)
        return 1


def main(argv=None) -> None:
    sys.exit(run_cli(cli, "svgen", argv))
