"""The ``svgen`` command line. Thin: each command lives in its own ``pipeline/commands/<name>.py`` module, loaded
lazily, so ``svgen --help`` does not import mitsuba or dask."""
from __future__ import annotations

import sys

import click

from svcore.cli import LazyGroup, run_cli, version_option
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


@click.group(cls=LazyGroup, registry=COMMANDS, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("-v", "--verbose", is_flag=True, help="Debug logging.")
@version_option("svgen")
def cli(verbose: bool) -> None:
    """svgen: procedural SVBRDF training data for single-image material capture."""
    configure(verbose)


def main(argv=None) -> None:
    sys.exit(run_cli(cli, "svgen", argv))
