"""`svgen stats STORE...`: map distributions of stores side by side (table, JSON, chart); with ``--reference REF``,
every realism statistic's distance from each store to REF beside REF's split-half noise floor (docs/REALISM.md)."""
from __future__ import annotations

import click

from svcore.cli import force_option

from ..cli_options import storage_option


def labels(paths) -> list[str]:
    """Each path's folder name, made unique by a #k suffix (two stores may share a name)."""
    from pathlib import Path

    out: list[str] = []
    for p in paths:
        name = Path(str(p).rstrip("/")).name
        out.append(name if name not in out else f"{name}#{sum(o.split('#')[0] == name for o in out) + 1}")
    return out


@click.command()
@storage_option
@click.argument("stores", nargs=-1, required=True, type=click.Path())
@click.option("--out", type=click.Path(file_okay=False), default=None,
              help="Folder for stats.json, stats.md and stats.png (with --reference also realism.json, realism.md "
                   "and realism.png; refused if it holds files, see --force) [default: print the tables only].")
@click.option("--limit", type=click.IntRange(min=1), default=None, help="At most N materials per store, evenly spaced.")
@click.option("--stride", type=click.IntRange(min=1), default=4, show_default=True, help="Use every N-th pixel.")
@click.option("--reference", type=click.Path(), default=None,
              help="A store of real materials (e.g. `svgen import` of a folder): print each realism statistic's "
                   "distance from every STORE to it, with its split-half noise floor (docs/REALISM.md).")
@click.option("--splits", type=click.IntRange(min=1), default=8, show_default=True,
              help="Random halvings of the reference averaged into the noise floor.")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Seed of the reference's halvings.")
@force_option("--out folders")
def stats(stores, out, limit, stride, reference, splits, seed, force):
    """Distributions of every map over one or more STORES, side by side."""
    import json
    from pathlib import Path

    from svcore.outputs import refuse_existing

    from ..stats import chart, store_stats, table

    if out:
        refuse_existing([out], force)  # before any work: the one overwrite rule
    if reference is not None:
        from ..stats.profile import check_reference

        check_reference(reference)
    results = [store_stats(s, limit, stride) for s in stores]
    md = table(results)
    click.echo(md)
    if out:
        d = Path(out)
        d.mkdir(parents=True, exist_ok=True)
        (d / "stats.json").write_text(json.dumps(results, indent=1))
        (d / "stats.md").write_text(md + "\n")
        chart(results, d / "stats.png")
        click.echo(f"wrote {d / 'stats.json'}, {d / 'stats.md'}, {d / 'stats.png'}")
    if reference is None:
        return
    from ..stats.realism_chart import chart as realism_chart
    from ..stats.compare import compare, table as realism_table
    from ..stats.profile import profile

    names = labels([reference, *stores])
    ref = profile(reference, limit, names[0])
    report = compare([profile(s, limit, n) for s, n in zip(stores, names[1:])], ref, splits, seed)
    md = realism_table(report)
    click.echo("")
    click.echo(md)
    if out:
        (d / "realism.json").write_text(json.dumps(report, indent=1) + "\n")
        (d / "realism.md").write_text(md + "\n")
        realism_chart(report, d / "realism.png")
        click.echo(f"wrote {d / 'realism.json'}, {d / 'realism.md'}, {d / 'realism.png'}")
