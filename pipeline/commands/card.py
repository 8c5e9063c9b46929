"""``svgen card STORE [--write]``: print, or regenerate, the dataset card (README.md) of a finished store."""
from __future__ import annotations

import click


@click.command("card")
@click.argument("store", type=click.Path(file_okay=False))
@click.option("--write", is_flag=True, help="Write the card to STORE/README.md (regenerate it) instead of printing it.")
def card(store: str, write: bool) -> None:
    """Print the dataset card of STORE (a complete svgen store of any kind), made from its own attributes."""
    from storage.store import card_text, write_card

    if write:
        click.echo(f"wrote {write_card(store)}")
    else:
        click.echo(card_text(store), nl=False)
