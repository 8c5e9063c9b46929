"""Where README.md and docs/*.md quote a results file, and whether each quote says when and on what it was measured.

A *quote* is a mention of a results file (``benchmarks/results/x.json``, ``results/x.json`` or ``x.json`` alone,
not a longer name or another folder's ``x.json``) in the prose or tables of a page; mentions inside fenced code
(commands that write the file) are not quotes. A quote's *block* is the table row, list item or paragraph that
holds it; its *span* runs from the mention to the next JSON file the block names (or the block's end), so that
each quoted file needs its own stamp, after its name.

A quote is *stamped* when its span gives the date and the commit of the measurement, as
``results/x.json (2026-11-26, commit 3f32302)`` (a date ``YYYY-MM-DD`` and the word ``commit`` before 7 to 40 hex
digits). A stamped quote stays true when the code moves on: it says which code its figures belong to.
benchmarks/stale.py ``--check --quoted`` fails on a quote of a stale or unknown results file that is not stamped.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

#: a date of the measurement in a quote's span.
DATE = re.compile(r"(?<![\w-])20\d\d-[01]\d-[0-3]\d(?![\w-])")
#: the commit of the measurement in a quote's span: "commit" and 7 to 40 hex digits (backticks allowed).
COMMIT = re.compile(r"\bcommit\s+`?([0-9a-f]{7,40})(?![\w])")
#: any JSON file named in a page: the ends of a quote's span.
ANY_JSON = re.compile(r"(?<![\w./-])(?:[\w.-]+/)*[\w.-]+\.json(?![\w-])")
#: the start of a block of its own: a table row, a heading, a list item.
_ROW, _HEADING = re.compile(r"^\s*\|"), re.compile(r"^#{1,6} ")
_ITEM = re.compile(r"^\s*(?:[-*+]|\d+\.)\s")


@dataclass(frozen=True)
class Quote:
    """One quote: the page (relative to the root), the 1-based line of the mention, and the spans of the block's
    mentions of the file (each to the next :data:`ANY_JSON`: the module docstring says why)."""

    doc: str
    line: int
    spans: tuple[str, ...]

    @property
    def stamped(self) -> bool:
        """Whether the span of one of the block's mentions gives a date and a commit."""
        return any(DATE.search(s) and COMMIT.search(s) for s in self.spans)


def spans(block: str, pat: re.Pattern) -> tuple[str, ...]:
    """The span of each mention ``pat`` finds in ``block``: from the mention to the next JSON name (or the end)."""
    starts = [m.start() for m in ANY_JSON.finditer(block)]
    return tuple(block[m.start():min((s for s in starts if s >= m.end()), default=len(block))]
                 for m in pat.finditer(block))


def pages(root: Path) -> list[Path]:
    """The pages that quote figures: README.md and docs/*.md."""
    return [p for p in [root / "README.md", *sorted((root / "docs").glob("*.md"))] if p.is_file()]


def blocks(text: str) -> list[tuple[int, list[str]]]:
    """The blocks of a page outside fenced code: (1-based first line, lines), split at blank lines, table rows,
    headings and list items."""
    out: list[tuple[int, list[str]]] = []
    fenced, current = False, None
    for k, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith("```"):
            fenced, current = not fenced, None
            continue
        if fenced or not line.strip():
            current = None
            continue
        own = bool(_ROW.match(line) or _HEADING.match(line))
        if own or _ITEM.match(line) or current is None:
            current = (k, [line])
            out.append(current)
            if own:
                current = None
        else:
            current[1].append(line)
    return out


def mention(name: str) -> re.Pattern:
    """A mention of the results file ``name`` (relative to benchmarks/results)."""
    return re.compile(r"(?<![\w./-])(?:(?:benchmarks/)?results/)?" + re.escape(name) + r"(?![\w-])")


def page_blocks(root: Path) -> list[tuple[str, int, list[str]]]:
    """Every block of every page under ``root``: (page relative to ``root``, first line, lines)."""
    return [(str(page.relative_to(root)), first, lines) for page in pages(root)
            for first, lines in blocks(page.read_text())]


def quotes(name: str, root: Path, read: list[tuple[str, int, list[str]]] | None = None) -> list[Quote]:
    """Every quote of the results file ``name`` in the pages under ``root``, in page and line order (one per
    block); ``read``: the pages' :func:`page_blocks`, when a caller looks up many names."""
    pat = mention(name)
    out = []
    for doc, first, lines in page_blocks(root) if read is None else read:
        hit = next((first + i for i, line in enumerate(lines) if name in line and pat.search(line)), None)
        if hit is not None:
            out.append(Quote(doc, hit, spans("\n".join(lines), pat)))
    return out
