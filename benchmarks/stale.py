"""List the results files whose measured code changed since they were written, and the figures they quote.

Every results file written through benchmarks/harness.py records the digest of the code it measured
(``code_digest``: the script, the benchmark modules and the project packages it imported; benchmarks/freshness.py
says why that scope). This script recomputes each digest on this checkout:

* stale: some of that code changed since (named), so its figures may no longer hold: measure again;
* unknown: no digest recorded (written before digests were);
* fresh: every digest matches (listed with --all).

For each file it lists its top-level figures and the documents that quote it (README.md, docs/*.md).

Usage: python3 benchmarks/stale.py [--all] [--check] [--results DIR]
"""
from __future__ import annotations

import json
from pathlib import Path

import freshness

from harness import RESULTS, ROOT, parser

#: figures shown per results file (the rest are counted).
SHOWN = 6


def headline(results: dict, shown: int = SHOWN) -> str:
    """The file's top-level numeric figures, ``key=value``, the first ``shown`` of them: measured figures (a
    name that says which way is better, :func:`freshness.direction`) before settings such as ``lr``."""
    top = {k: v for k, v in freshness.figures(results).items() if "." not in k}
    top = dict(sorted(top.items(), key=lambda kv: freshness.direction(kv[0]) == 0))
    items = [f"{k}={v:.4g}" for k, v in list(top.items())[:shown]]
    if len(top) > shown:
        items.append(f"+{len(top) - shown} more")
    return ", ".join(items) if items else "(no top-level figures)"


def quoted_in(name: str, root: Path = ROOT) -> list[str]:
    """The documents (README.md, docs/*.md) that name the results file ``name``."""
    docs = [root / "README.md", *sorted((root / "docs").glob("*.md"))]
    return [str(d.relative_to(root)) for d in docs if d.is_file() and name in d.read_text()]


def survey(results_dir: Path = RESULTS, root: Path = ROOT) -> list[tuple[Path, freshness.Freshness, dict]]:
    """(path, freshness, results) of every results JSON under ``results_dir``, in path order."""
    out = []
    for p in sorted(results_dir.rglob("*.json")):
        try:
            data = json.loads(p.read_text())
        except ValueError:
            continue
        if isinstance(data, dict):
            out.append((p, freshness.freshness(data, root), data))
    return out


def main(argv=None) -> int:
    ap = parser(__doc__, note=False)
    ap.add_argument("--all", action="store_true", help="list the fresh results files too")
    ap.add_argument("--check", action="store_true", help="exit 1 when a results file is stale")
    ap.add_argument("--results", default=str(RESULTS), help="the results folder (default benchmarks/results)")
    a = ap.parse_args(argv)
    rows = survey(Path(a.results))
    counts = {"stale": 0, "unknown": 0, "fresh": 0}
    for path, f, data in rows:
        counts[f.state] += 1
        if f.state == "fresh" and not a.all:
            continue
        name = str(path.relative_to(Path(a.results)))
        why = {"stale": "changed: " + ", ".join(f.changed), "unknown": "no code digest recorded",
               "fresh": "code unchanged"}[f.state]
        docs = quoted_in(name)
        print(f"{f.state:7s} {name}  ({why})")
        print(f"        figures: {headline(data)}" + (f"; quoted in {', '.join(docs)}" if docs else ""))
    print(f"{counts['stale']} stale, {counts['unknown']} unknown, {counts['fresh']} fresh of {len(rows)} results "
          "files")
    return 1 if a.check and counts["stale"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
