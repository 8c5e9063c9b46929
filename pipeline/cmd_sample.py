"""`svgen sample OUT`: perturbed variants of the base materials -> variants store."""
from __future__ import annotations

import click

from .cli_options import config_options, parallel_options
from .config import SampleConfig, build


@click.command()
@click.argument("out", type=click.Path())
@click.option("--per-preset", type=int, default=None, help="Variants per base material [default: 12].")
@click.option("--size", type=int, default=None, help="Map resolution, 64..1024 [default: 256].")
@click.option("--seed", type=int, default=None, help="Master seed of the stage [default: 0].")
@click.option("--sigma", type=float, default=None, help="Perturbation width as a fraction of each range [default: 0.25].")
@click.option("--preset", "presets", multiple=True, help="Only this base material (repeatable).")
@click.option("--class", "classes", multiple=True, help="Only this material class (repeatable).")
@click.option("--chunk", type=int, default=None, help="Samples per zarr chunk [default: 8].")
@click.option("--from", "from_stores", multiple=True, type=click.Path(),
              help="An imported variants store (svgen import) whose materials are perturbed too (repeatable).")
@click.option("--from-dir", type=click.Path(file_okay=False), default=None,
              help="Every *.zarr store in this folder, as --from (an empty or missing folder adds none).")
@click.option("--per-material", type=int, default=None,
              help="Variants per imported material [default: params.yaml import.per_material, else 3].")
@click.option("--only-from", is_flag=True, help="With --from: no preset variants, only the imported materials'.")
@config_options("sample")
@parallel_options
def sample(out, per_preset, size, seed, sigma, presets, classes, chunk, from_stores, from_dir, per_material, only_from,
           config_name, params_file, workers, scheduler_address):
    """Perturb every base material's parameters into a variants store at OUT."""
    from .sample import run_sample

    cfg = build(SampleConfig, config_name, params_file, "sample", per_preset=per_preset, size=size, seed=seed,
                sigma=sigma, presets=presets or None, classes=classes or None, chunk=chunk)
    stores = list(from_stores)
    if from_dir:
        from pathlib import Path

        stores += sorted(str(p) for p in Path(from_dir).glob("*.zarr")) if Path(from_dir).is_dir() else []
    if stores:  # imported materials join the presets' variants (pipeline/sample_from.py)
        from .config import ImportConfig
        from .sample_from import run_sample_from

        if per_material is None:
            per_material = build(ImportConfig, "default", params_file, "import").per_material

        path = run_sample_from(out, cfg, stores, per_material, not only_from, workers=workers,
                               scheduler_address=scheduler_address)
    else:
        path = run_sample(out, cfg, workers=workers, scheduler_address=scheduler_address)
    click.echo(f"wrote {path}")
