"""What both command lines (``svgen``, ``svtrain``) share: the one-line error funnel, ``--version`` and the lazy
command registry.

:func:`run_cli` is the only place that turns exceptions into exit codes: user errors (the
:class:`~svcore.errors.SvgenError` family and click's usage errors) print one line and exit 2, environment
errors (full disk, permissions) one line and exit 1, anything else one line naming it as an internal error
(``SVGEN_DEBUG=1`` shows the traceback).
"""
from __future__ import annotations

import errno
import importlib
import importlib.util
import os
import sys

import click

from .errors import SvgenError

_OS_HINTS = {errno.ENOSPC: "free space and rerun: completed chunks are kept and the run resumes",
             errno.EDQUOT: "free quota and rerun: completed chunks are kept and the run resumes",
             errno.EFBIG: "file size limit reached; raise it and rerun",
             errno.EACCES: "check the permissions of the output location"}


def one_line(msg: object) -> str:
    """Messages from libraries can span lines (YAML, zarr, pydantic); the CLI promises one."""
    return " ".join(str(msg).split())


def version() -> str:
    """The package version with the code's digest (:func:`svcore.versions.svgen_version`), what results record."""
    from .versions import svgen_version

    return svgen_version()


def version_detail() -> str:
    """What ``--version`` adds in brackets: the source digest and, in a git checkout, ``git describe`` (whose
    "-dirty" also counts edited data files such as dvc.lock, so it is a detail, never the version)."""
    from .versions import SHORT_DIGEST, code_digest, git_description

    git = git_description()
    return f"code {code_digest()[:SHORT_DIGEST]}" + (f", git {git}" if git else "")


class _VersionMessage(str):
    """click's version message, formatted when ``--version`` is given (not at import: git runs only then)."""

    def __mod__(self, values):
        return f"{values['prog']} {values['version']} ({version_detail()})"


def version_option(prog: str):
    """``--version``: ``PROG PACKAGE_VERSION (code DIGEST, git DESCRIBE)`` and exit 0; the package version from its
    metadata (click.version_option)."""
    return click.version_option(package_name="svgen", prog_name=prog, message=_VersionMessage("%(prog)s %(version)s"),
                                help="Print the package version (with the source digest and git describe) and exit.")


class LazyGroup(click.Group):
    """A click group whose commands live one per module, named by a registry and imported only when run or listed
    in help, so that ``PROG --help`` imports no stage (``svgen``: mitsuba and dask; ``svtrain``: torch).

    The registry maps command name -> ``"module:attribute"`` (``@click.group(cls=LazyGroup, registry=COMMANDS)``);
    help lists the commands in its order. A command whose module is not installed is left out.
    """

    def __init__(self, *args, registry: dict[str, str], **kwargs):
        super().__init__(*args, **kwargs)
        self.registry = registry

    def list_commands(self, ctx):
        return [name for name in self.registry if self._importable(name)]

    def get_command(self, ctx, name):
        if name not in self.registry:
            return None
        mod, attr = self.registry[name].split(":")
        try:
            return getattr(importlib.import_module(mod), attr)
        except ModuleNotFoundError as e:
            if e.name == mod:
                return None
            raise

    def _importable(self, name: str) -> bool:
        return importlib.util.find_spec(self.registry[name].split(":")[0]) is not None


def force_option(what: str = "outputs"):
    """``--force``: the one flag that lets a command write over existing outputs (the rule:
    :func:`svcore.outputs.refuse_existing`). ``what`` names them in the help."""
    from .outputs import FORCE_FLAG

    return click.option(FORCE_FLAG, "force", is_flag=True,
                        help=f"Overwrite existing {what} (without it an existing output is refused).")


def run_cli(group: click.Group, prog: str, argv=None) -> int:
    """Run a click group; user errors become one line on stderr and exit code 2 (no traceback).

    Set ``SVGEN_DEBUG=1`` to see tracebacks of unexpected errors.
    """
    code = _run_cli(group, prog, argv)
    if code and not os.environ.get("SVGEN_DEBUG"):
        # the error is reported: what async clients abandon by it (an s3fs request still pending when the endpoint
        # went away) must not add a traceback at exit ("Exception ignored in: <coroutine ...>")
        sys.unraisablehook = _quiet_unraisable
    return code


def _quiet_unraisable(unraisable) -> None:
    from .log import get_logger

    get_logger(__name__).debug("ignored at exit: %s", unraisable.exc_value)


def _run_cli(group: click.Group, prog: str, argv=None) -> int:
    try:
        group.main(args=argv, prog_name=prog, standalone_mode=False)
        return 0
    except click.exceptions.Abort:
        click.echo(f"{prog}: aborted", err=True)
        return 130
    except click.exceptions.Exit as e:
        return e.exit_code
    except click.exceptions.NoArgsIsHelpError as e:  # a bare `svgen`: the help asked for, not a usage error
        click.echo(e.ctx.get_help() if e.ctx is not None else group.get_help(click.Context(group, info_name=prog)))
        return 0
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


# -- configuration on the command line ---------------------------------------------------------------------
class ConfigCommand(click.Command):
    """A click command whose ``--help`` ends with every key of its config (settable by ``--set`` and params.yaml):
    type, default of the default preset, and the field's documentation."""

    config_cls = None

    def format_epilog(self, ctx, formatter) -> None:
        from .config import PRESET_KEY, keys, preset_values, type_name

        cls = self.config_cls
        defaults = preset_values(cls)
        rows = [(k, f"({type_name(ann)}, default {show(defaults.get(k))}) {doc}") for k, ann, _, doc in keys(cls)]
        rows.insert(0, (PRESET_KEY, f"(one of {', '.join(cls.PRESETS)}, default {cls.DEFAULT_PRESET!r}) the named "
                                    "preset the other keys start from"))
        with formatter.section(f"Config keys (--set KEY=VALUE, or section '{cls.SECTION}' of a --params file)"):
            formatter.write_dl(rows)
        super().format_epilog(ctx, formatter)


def show(value) -> str:
    """A default as params.yaml spells it (true, null, 0.25, [a, b])."""
    import yaml

    return yaml.safe_dump(value, default_flow_style=True, width=1 << 16).strip().removesuffix("...").strip()


def _click_type(ann):
    import typing

    from .config import _unwrap

    ann = _unwrap(ann)
    if typing.get_origin(ann) is typing.Literal:
        return click.Choice([str(a) for a in typing.get_args(ann)]), False
    if typing.get_origin(ann) in (tuple, list):
        return _click_type(typing.get_args(ann)[0])[0], True
    return {int: click.INT, float: click.FLOAT, str: click.STRING, bool: click.BOOL}.get(ann, click.STRING), False


def _param(key: str) -> str:
    return "cfg__" + key.replace(".", "__")


def config_command(cls, flags: dict[str, str], envvars: dict[str, str] | None = None, paths: tuple[str, ...] = (),
                   **command_kw):
    """Decorator: a click command configured by ``cls``.

    Adds ``--config-preset``, ``--params FILE``, ``--set KEY=VALUE`` (repeatable), ``--print-config``, and one
    flag per entry of ``flags`` (dotted config key -> flag spelling, e.g. ``{"per_preset": "--per-preset"}``;
    a bool key may be spelled ``"--on/--off"``), each with the field's documentation as help. The command
    function receives ``cfg`` (the resolved config) instead of these options; ``--print-config`` prints it as
    params.yaml YAML and exits 0 before the command runs. ``envvars`` (dotted key -> environment variable) lets
    a machine setting's flag be read from the environment when it is not given (it then wins over params.yaml
    like the flag would): settings such as worker counts, which change no output byte, stay out of params.yaml.
    ``paths`` names the keys whose values are paths: their flags are ``click.Path`` options, which a store's
    history records relative to the store (:mod:`svcore.history`).
    """
    from .config import PRESET_FLAG, field, preset_values

    def deco(fn):
        import functools

        defaults = preset_values(cls)

        @functools.wraps(fn)
        def wrapper(*args, **kw):
            return fn(*args, cfg=config_from_cli(cls, kw), **kw)

        f = wrapper
        for key, flag in reversed(list(flags.items())):
            info = field(cls, key)
            typ, multiple = _click_type(info.annotation)
            typ = click.Path() if key in paths else typ
            doc = " ".join((info.description or "").split())
            if "/" in flag:  # a boolean switch pair
                f = click.option(flag, _param(key), default=None,
                                 help=f"{doc} [config key {key}; default: {show(defaults[key])}]")(f)
            elif multiple:
                f = click.option(flag, _param(key), type=typ, multiple=True,
                                 help=f"{doc} Repeatable. [config key {key}]")(f)
            else:
                env = (envvars or {}).get(key)
                f = click.option(flag, _param(key), type=typ, default=None, envvar=env, show_envvar=env is not None,
                                 help=f"{doc} [config key {key}; default: {show(defaults[key])}]")(f)
        f = click.option("--print-config", is_flag=True,
                         help=f"Print the resolved config as a '{cls.SECTION}:' params.yaml section and exit.")(f)
        f = click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
                         help="Set any config key listed below (YAML value; repeatable). Flags override it.")(f)
        f = click.option("--params", "params_file", type=click.Path(dir_okay=False), default=None,
                         help=f"A params.yaml whose '{cls.SECTION}' section sets the config (--set and flags "
                              "override it).")(f)
        f = click.option(PRESET_FLAG, "config_preset", type=click.Choice(list(cls.PRESETS)), default=None,
                         help=f"Named config preset the other values start from [default: {cls.DEFAULT_PRESET}].")(f)
        cmd = click.command(cls=ConfigCommand, **command_kw)(f)
        cmd.config_cls = cls
        return cmd

    return deco


def config_from_cli(cls, kw: dict):
    """Pop the config options of :func:`config_command` from ``kw`` and resolve them (``--print-config`` exits)."""
    from .config import params_text, parse_sets, resolve

    flags = {}
    for name in [k for k in kw if k.startswith("cfg__")]:
        val = kw.pop(name)
        flags[name[5:].replace("__", ".")] = (tuple(val) or None) if isinstance(val, tuple) else val
    cfg = resolve(cls, kw.pop("config_preset"), kw.pop("params_file"), parse_sets(kw.pop("sets")), flags)
    if kw.pop("print_config"):
        click.echo(params_text(cfg), nl=False)
        raise click.exceptions.Exit(0)
    return cfg


def require(**args) -> None:
    """Positional arguments left optional so that ``--print-config`` works without them: check them here."""
    for name, val in args.items():
        if val is None or val == ():
            raise click.UsageError(f"Missing argument '{name.upper()}'.")
