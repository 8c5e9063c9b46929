"""docs/ARCHITECTURE.md's map matches the tree (issue #41): every module of the installed packages and every file of
scripts/ has a line, and every file or folder the map names exists.

The map is the first fenced block after "## The map". A line at column 0 names a top folder (``pipeline/``); a line
indented 2 or 4 spaces starts with one or more comma-separated names (``a.py, b.py``, or a subfolder ``render/``
whose ``__init__.py`` it stands for) and, two spaces on, a description; deeper lines continue a description.
"""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "ARCHITECTURE.md"
#: top folders whose every file must be on the map, beside the installed packages (and which files count)
FULL_FOLDERS = {"scripts": ("*.py", "*.sh")}
NAME = re.compile(r"[\w.-]+(/[\w.-]+)*/?")


def packages() -> list[str]:
    """The installed top-level packages: pyproject's ``[tool.setuptools.packages.find] include``."""
    find = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]["find"]
    return sorted({pattern.rstrip("*").rstrip(".") for pattern in find["include"]})


def map_block(text: str) -> list[str]:
    """The lines of the map's fenced block."""
    m = re.search(r"^## The map\n.*?^```\n(.*?)^```", text, re.S | re.M)
    assert m, "docs/ARCHITECTURE.md lost its map (a fenced block under '## The map')"
    return m.group(1).splitlines()


def listed(lines: list[str]) -> set[str]:
    """Paths relative to the repository the map names: files, and folders as ``folder/``."""
    out: set[str] = set()
    top = sub = None
    for k, line in enumerate(lines, 1):
        if not line.strip():
            continue
        indent = len(line) - len(line.lstrip(" "))
        if indent > 4:
            continue  # a description's continuation
        names = re.split(r"\s{2,}", line.strip(), maxsplit=1)[0]
        tokens = [t.strip() for t in names.split(",") if t.strip()]
        bad = [t for t in tokens if not NAME.fullmatch(t)]
        assert tokens and not bad, f"map line {k}: cannot read the names {bad or names!r} (two spaces before a " \
                                   f"description): {line!r}"
        if indent == 0:
            assert len(tokens) == 1 and tokens[0].endswith("/"), f"map line {k}: a top folder is one 'name/'"
            top, sub = tokens[0], None
            out.add(top)
            continue
        assert top, f"map line {k}: a name before any top folder"
        base = top if indent == 2 else sub
        assert base, f"map line {k}: indented 4 outside a subfolder"
        for t in tokens:
            out.add(base + t)
        if indent == 2:
            sub = base + tokens[0] if len(tokens) == 1 and tokens[0].endswith("/") else None
    return out


def covered(names: set[str]) -> set[str]:
    """The files the named paths stand for: each file, and each folder's ``__init__.py``."""
    return {n for n in names if not n.endswith("/")} | {n + "__init__.py" for n in names if n.endswith("/")}


def in_tree() -> set[str]:
    """The files that must be on the map."""
    files = {p for pkg in packages() for p in (ROOT / pkg).rglob("*.py") if "__pycache__" not in p.parts}
    files |= {p for folder, patterns in FULL_FOLDERS.items() for pat in patterns for p in (ROOT / folder).glob(pat)}
    return {p.relative_to(ROOT).as_posix() for p in files}


def check(text: str) -> tuple[list[str], list[str]]:
    """(files of the tree the map misses, names on the map without a file or folder)."""
    names = listed(map_block(text))
    missing = sorted(in_tree() - covered(names))
    absent = sorted(n for n in names if not ((ROOT / n).is_dir() if n.endswith("/") else (ROOT / n).is_file()))
    return missing, absent


def test_the_packages_are_the_installed_ones():
    assert packages() == ["materials", "pipeline", "storage", "svcore", "train"]


def test_every_module_is_on_the_map_and_every_name_on_it_exists():
    missing, absent = check(DOC.read_text())
    assert not missing, f"docs/ARCHITECTURE.md's map misses {missing}: give each a line"
    assert not absent, f"docs/ARCHITECTURE.md's map names {absent}, which do not exist"


def test_the_check_sees_a_dropped_module_and_an_invented_one():
    """The parser reads what it should: the real map with one module line dropped, or a module added, fails."""
    text = DOC.read_text()
    missing, absent = check(text)
    dropped = re.sub(r"^  srgb\.py .*\n", "", text, count=1, flags=re.M)
    assert dropped != text and check(dropped) == (sorted([*missing, "svcore/srgb.py"]), absent)
    invented = text.replace("  srgb.py ", "  srgb.py, gamma.py ", 1)
    assert check(invented) == (missing, sorted([*absent, "svcore/gamma.py"]))
