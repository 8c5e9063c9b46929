"""The documentation's shape (issue #41): a README of at most 300 lines that is a front door (the two commands at
the top, short lines, links into docs/), relative links and anchors that resolve, and every image in docs/img shown
somewhere."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MAX_LINES, MAX_WIDTH = 300, 120
#: the pages the README must link (issue #41: LIMITS, PERFORMANCE with the charts, REALISM, IMPORT, CONVENTIONS,
#: ARCHITECTURE, the experiments index)
FRONT_DOOR_LINKS = ("docs/LIMITS.md", "docs/PERFORMANCE.md", "docs/REALISM.md", "docs/IMPORT.md",
                    "docs/CONVENTIONS.md", "docs/ARCHITECTURE.md", "experiments/README.md")
#: the charts docs/PERFORMANCE.md shows (the ones `dvc plots show` draws: tests/test_dvc_hygiene.py)
PERFORMANCE_CHARTS = ("render", "training", "scaleout", "agreement", "stress")
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def prose_lines(text: str) -> list[tuple[int, str]]:
    """(line number, line) of ``text`` outside fenced code blocks."""
    out, fenced = [], False
    for k, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if not fenced:
            out.append((k, line))
    return out


def documents() -> list[Path]:
    """Every markdown page of the documentation: the README, docs/, the experiments' index and reports."""
    return [README, *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "experiments").rglob("*.md"))]


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces as hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    return {slug(line.lstrip("#")) for _, line in prose_lines(path.read_text()) if re.match(r"#{1,6} ", line)}


def links(path: Path) -> list[tuple[int, str]]:
    """(line number, target) of every markdown link and image outside code blocks."""
    return [(k, m.group(1)) for k, line in prose_lines(path.read_text()) for m in LINK.finditer(line)]


def test_the_readme_is_a_front_door():
    """At most 300 lines, none wider than 120 characters outside tables and fenced code, the two commands at the top
    exactly as scripts/ and .ci/run run them, and links to the pages issue #41 names."""
    text = README.read_text()
    lines = text.splitlines()
    assert len(lines) <= MAX_LINES, f"README.md has {len(lines)} lines, at most {MAX_LINES}: move detail into docs/"
    wide = [(k, len(line)) for k, line in prose_lines(text) if not line.startswith("|") and len(line) > MAX_WIDTH]
    assert not wide, f"README.md lines wider than {MAX_WIDTH} characters (line, width): {wide}"
    commands = [line for line in lines[:30] if line.startswith("    bash ")]
    assert commands == ["    bash scripts/run.sh", "    bash scripts/test.sh"], commands
    targets = {t for _, t in links(README)}
    assert not [d for d in FRONT_DOOR_LINKS if d not in targets], [d for d in FRONT_DOOR_LINKS if d not in targets]


def test_the_performance_page_shows_the_charts():
    page = ROOT / "docs" / "PERFORMANCE.md"
    shown = {t for _, t in links(page)}
    missing = [c for c in PERFORMANCE_CHARTS if f"img/chart_{c}.png" not in shown]
    assert not missing, f"docs/PERFORMANCE.md does not show {missing}"


def test_every_relative_link_and_anchor_resolves():
    """Each link or image of every page that is not a URL names a file or folder that exists, relative to the page;
    an anchor (``page.md#heading``, ``#heading``) names a heading of that page."""
    bad = []
    for doc in documents():
        for k, target in links(doc):
            if re.match(r"[a-z]+:", target):  # https:, mailto:
                continue
            path, _, anchor = target.partition("#")
            dest = (doc.parent / path).resolve() if path else doc
            where = f"{doc.relative_to(ROOT)}:{k}: {target}"
            if not dest.exists():
                bad.append(f"{where} (no such file)")
            elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                bad.append(f"{where} (no such heading)")
    assert not bad, "\n".join(bad)


def test_every_image_in_docs_img_is_shown_or_linked():
    """No figure is lost when text moves: every PNG in docs/img is the target of a link or image of some page."""
    used = {(doc.parent / t.partition("#")[0]).resolve() for doc in documents() for _, t in links(doc)}
    orphans = sorted(p.name for p in (ROOT / "docs" / "img").glob("*.png") if p.resolve() not in used)
    assert not orphans, f"images in docs/img that no page shows or links: {orphans}"


def code_lines(text: str) -> list[str]:
    """What a page shows as code, a line or span each: fenced blocks, indented code lines, inline code spans."""
    out, prose, fenced = [], [], False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif fenced or line.startswith("    ") and not line.lstrip().startswith(("-", "*", "|")):
            out.append(line)
        else:
            prose.append(line)
    return out + [" ".join(s.split()) for s in re.findall(r"`([^`]+)`", "\n".join(prose))]


def test_every_command_the_pages_name_exists():
    """``svgen NAME`` and ``svtrain NAME`` at the start of a command in the pages' code name commands of the two CLIs (text that moved from
    the README keeps its commands current)."""
    from pipeline.cli import COMMANDS
    from train.cli import COMMANDS as SVTRAIN_COMMANDS

    known = {"svgen": set(COMMANDS), "svtrain": set(SVTRAIN_COMMANDS)}
    assert len(known["svgen"]) == 11 and len(known["svtrain"]) == 7, known
    named = {(doc.relative_to(ROOT).as_posix(), tool, cmd) for doc in documents()
             for line in code_lines(doc.read_text())
             for tool, cmd in re.findall(r"(?:^|&&)\s*(svgen|svtrain) ([a-z][\w-]*)", line)}
    assert {c for _, t, c in named if t == "svgen"} >= {"sample", "render", "import"}  # the scan sees them
    unknown = sorted(n for n in named if n[2] not in known[n[1]])
    assert not unknown, f"pages name commands that do not exist: {unknown}"
