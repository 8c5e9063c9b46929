"""List the results files whose measured code changed since they were written, and the figures they quote.

Every results file written through benchmarks/harness.py records the digest of the code it measured
(``code_digest``: the script, the benchmark modules and the project packages it imported; benchmarks/freshness.py
says why that scope). This script recomputes each digest on this checkout:

* stale: some of that code changed since (named), so its figures may no longer hold: measure again;
* unknown: no digest recorded (written before digests were);
* fresh: every digest matches (listed with --all).

For each file it lists its top-level figures and the documents that quote it (README.md, docs/*.md).

``--quoted`` looks at the quoted files only, and at each quote (benchmarks/quotes.py): a quote of a stale or
unknown file must give the date and commit of the measurement (``2026-11-26, commit 3f32302``), so that it says
which code its figures belong to. With ``--check`` it exits 1 when one does not (tests/test_stale.py runs this on
the repository, so the README's test command fails on it).

Usage: python3 benchmarks/stale.py [--all] [--check] [--quoted] [--results DIR] [--root DIR]
"""
from __future__ import annotations

import json
from pathlib import Path

import freshness
import quotes

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


def quoted_in(name: str, root: Path = ROOT, read=None) -> list[str]:
    """The documents (README.md, docs/*.md) that quote the results file ``name`` (:func:`quotes.quotes`)."""
    return list(dict.fromkeys(q.doc for q in quotes.quotes(name, root, read)))


def survey(results_dir: Path = RESULTS, root: Path = ROOT) -> list[tuple[Path, freshness.Freshness, dict]]:
    """(path, freshness, results) of every results JSON under ``results_dir``, in path order."""
    out, cache = [], {}
    for p in sorted(results_dir.rglob("*.json")):
        try:
            data = json.loads(p.read_text())
        except ValueError:
            continue
        if isinstance(data, dict):
            out.append((p, freshness.freshness(data, root, cache), data))
    return out


def main(argv=None) -> int:
    ap = parser(__doc__, note=False)
    ap.add_argument("--all", action="store_true", help="list the fresh results files too")
    ap.add_argument("--check", action="store_true",
                    help="exit 1 when a results file is stale (with --quoted: when a quote of a stale or unknown "
                         "file gives no date and commit)")
    ap.add_argument("--quoted", action="store_true",
                    help="only the files README.md or docs/*.md quote, with each quote and whether it is dated")
    ap.add_argument("--results", default=None, help="the results folder (default ROOT/benchmarks/results)")
    ap.add_argument("--root", default=str(ROOT),
                    help="the repository whose code and pages are read (default: this one)")
    a = ap.parse_args(argv)
    root = Path(a.root).resolve()
    results = Path(a.results) if a.results else root / "benchmarks" / "results"
    rows = survey(results, root)
    read = quotes.page_blocks(root)
    counts = {"stale": 0, "unknown": 0, "fresh": 0}
    undated = 0
    for path, f, data in rows:
        name = path.relative_to(results).as_posix()
        found = quotes.quotes(name, root, read) if a.quoted else []
        if a.quoted and not found:
            continue
        counts[f.state] += 1
        if f.state == "fresh" and not a.all:
            continue
        why = {"stale": "changed: " + ", ".join(f.changed), "unknown": "no code digest recorded",
               "fresh": "code unchanged"}[f.state]
        print(f"{f.state:7s} {name}  ({why})")
        if not a.quoted:
            docs = quoted_in(name, root, read)
            print(f"        figures: {headline(data)}" + (f"; quoted in {', '.join(docs)}" if docs else ""))
            continue
        print(f"        figures: {headline(data)}")
        for q in found:
            ok = q.stamped or f.state == "fresh"
            undated += not ok
            state = "dated" if q.stamped else ("fresh" if ok else "NO DATE AND COMMIT")
            print(f"        quoted in {q.doc}:{q.line}: {state}")
    what = "quoted results files" if a.quoted else "results files"
    print(f"{counts['stale']} stale, {counts['unknown']} unknown, {counts['fresh']} fresh of {sum(counts.values())} "
          f"{what}")
    if a.quoted:
        print(f"{undated} quote(s) of a stale or unknown file without the date and commit of the measurement"
              + (": add them beside the quote (e.g. '2026-11-26, commit 3f32302') or measure again" if undated
                 else ""))
        return 1 if a.check and undated else 0
    return 1 if a.check and counts["stale"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
