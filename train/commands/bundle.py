"""``svtrain bundle``: make a run the model shipped with svgen, with its evaluated model card (:mod:`train.bundle`,
DVC stage train_bundled)."""
from __future__ import annotations

import click

from . import wrote


@click.command()
@click.argument("run")
@click.option("--stress-store", default=None, help="A `svgen stress` renders store: the card's stress table and "
              "known failure cases.")
@click.option("--reference-store", default=None, help="The reference renders store (`svgen reference OUT`: "
              "OUT/renders.zarr): the card's real-material table, when --params lists reference sources.")
@click.option("--params", "params_file", default="params.yaml", show_default=True,
              help="The params file whose reference.sources says whether there is a reference (empty: no table).")
@click.option("--into", default=None, help="Folder to write (default: the package's train/bundled).")
@click.option("--limit", type=int, default=400, show_default=True, help="Held-out views evaluated for the card.")
@click.option("--final", is_flag=True, help="Not a placeholder: drop the card's placeholder notice.")
@click.option("--device", default="cpu", show_default=True, help="auto, cpu, cuda, cuda:N or mps.")
def bundle(run, stress_store, reference_store, params_file, into, limit, final, device):
    """Make RUN the model shipped with svgen: weights-only model.pt, bundled.json and MODEL_CARD.md (evaluated)."""
    from ..bundle import bundle as run_bundle

    out = run_bundle(run, stress_store, into, limit, placeholder=not final, device=device,
                     reference_store=reference_store, params_file=params_file)
    wrote(out, "model.pt, bundled.json, MODEL_CARD.md")
