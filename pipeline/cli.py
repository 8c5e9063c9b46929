"""The ``svgen`` command line. Thin: each command lives in its own ``pipeline/commands/<name>.py`` module, loaded
lazily, so ``svgen --help`` does not import mitsuba or dask."""
from __future__ import annotations

import importlib
import sys

import click

from svcore.cli import run_cli, version_option
from svcore.log import configure

#: command name -> "module:attribute" (a registry instead of an if-chain; add a line to add a command).
COMMANDS: dict[str, str] = {
    "materials": "pipeline.commands.materials:materials",
    "sample": "pipeline.commands.sample:sample",
    "blend": "pipeline.commands.blend:blend",
    "render": "pipeline.commands.render:render",
    "export": "pipeline.commands.export:export",
    "stress": "pipeline.commands.stress:stress",
    "import": "pipeline.commands.import_:import_",
    "reference": "pipeline.commands.reference:reference",
    "stats": "pipeline.commands.stats:stats",
    "card": "pipeline.commands.card:card",
    "gallery": "pipeline.commands.gallery:gallery",
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
@version_option("svgen")
def cli(verbose: bool) -> None:
    """svgen: procedural SVBRDF training data for single-image material capture."""
    configure(verbose)


def main(argv=None) -> None:
    sys.exit(run_cli(cli, "svgen", argv))
