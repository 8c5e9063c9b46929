"""What the project's own files name exists: every project module imported by a shell script, a doc or a config
(``from svcore.mi_env import ...``, ``python3 -m train.cli``) imports, and every repository file named in the
packages' comments and in docs/ is there. A move that leaves a name behind (setup.sh still importing
``pipeline.mi_env`` after #41 moved it to ``svcore``) fails here instead of on a fresh machine."""
from __future__ import annotations

import importlib.util
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OWN = r"(?:pipeline|svcore|storage|train|materials)"
MODULE = re.compile(rf"(?:^|[\s;(])(?:from\s+({OWN}(?:\.\w+)*)\s+import\b|import\s+({OWN}(?:\.\w+)*)\b"
                    rf"|python3?\s+-m\s+({OWN}(?:\.\w+)*))", re.M)
PATH = re.compile(r"(?<![\w/.])((?:pipeline|svcore|storage|train|materials|benchmarks|experiments|scripts|tests"
                  r"|docs)/[\w/.-]+\.(?:py|sh|md|json|yaml))")
TEXT = (".sh", ".md", ".yaml", ".yml", ".toml", ".cfg", ".txt")


def tracked() -> list[str]:
    return subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()


def modules_named(text: str) -> set[str]:
    return {next(g for g in m.groups() if g) for m in MODULE.finditer(text)}


def missing_modules(files: list[str]) -> dict[str, str]:
    out = {}
    for f in files:
        for mod in modules_named((ROOT / f).read_text(errors="replace")):
            if _find(mod) is None:
                out[mod] = f
    return out


def _find(mod: str):
    try:
        return importlib.util.find_spec(mod)
    except ModuleNotFoundError:
        return None


def test_the_pattern_finds_what_setup_sh_once_got_wrong():
    # the failure this file guards against, as it was: the pattern must see it and find_spec must refuse it
    text = "$PY - <<'PY'\nfrom pipeline.mi_env import load_mitsuba\nPY\npython3 -m train.cli --help\n"
    assert modules_named(text) == {"pipeline.mi_env", "train.cli"}
    assert _find("pipeline.mi_env") is None and _find("svcore.mi_env") is not None


def test_modules_named_outside_python_import():
    files = [f for f in tracked() if f.endswith(TEXT) and not f.startswith("CHANGELOG") and (ROOT / f).is_file()]
    assert any(f == "scripts/setup.sh" for f in files)
    assert missing_modules(files) == {}, "modules named in scripts/docs that no longer import (moved or renamed?)"


def test_files_named_in_the_packages_and_docs_exist():
    files = [f for f in tracked() if (f.startswith(("pipeline/", "svcore/", "storage/", "train/", "materials/"))
                                      and f.endswith(".py")) or (f.startswith("docs/") and f.endswith(".md"))]
    gone = {}
    for f in files:
        for p in PATH.findall((ROOT / f).read_text(errors="replace")):
            p = p.rstrip(".")
            if not (ROOT / p).exists():
                gone[p] = f
    assert gone == {}, "files named in comments or docs that are not in the repository (moved?)"
