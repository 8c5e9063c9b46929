"""`svgen sample OUT`: perturbed variants of the base materials -> variants store."""
from __future__ import annotations

import click

from svcore.cli import config_command, require

from ..cli_options import parallel_options
from ..config import SampleConfig


@config_command(SampleConfig, {"per_preset": "--per-preset", "size": "--size", "seed": "--seed", "sigma": "--sigma",
                               "presets": "--preset", "classes": "--class", "chunk": "--chunk",
                               "from_stores": "--from", "from_dir": "--from-dir", "per_material": "--per-material",
                               "only_from": "--only-from/--with-presets"}, paths=("from_stores", "from_dir"))
@click.argument("out", type=click.Path(), required=False)
@parallel_options
def sample(out, cfg, workers, scheduler_address):
    """Perturb every base material's parameters into a variants store at OUT.

    With --from (or --from-dir), the materials of imported variants stores (`svgen import`) are perturbed too.
    """
    from ..sample import run_sample

    require(out=out)
    path = run_sample(out, cfg, workers=workers, scheduler_address=scheduler_address)
    click.echo(f"wrote {path}")
