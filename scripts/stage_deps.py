"""Which project modules each DVC stage's command imports, and which of them its ``deps`` miss.

    python3 scripts/stage_deps.py            # per stage: the project files its command imports that no dep covers

A stage must rerun when code that shapes its outputs changes, so its ``deps`` in dvc.yaml must cover every module
of the project packages (:data:`PACKAGES`) that its command imports, directly or through other project modules.
The import graph is read from the source (:mod:`svcore.codegraph`, which also names the code a store records), not
by importing. Entry points of a command:

- ``svgen SUB``: pipeline/cli.py and the module of ``pipeline.cli.COMMANDS[SUB]``;
- ``svtrain SUB``: train/cli.py and the module of ``train.cli.COMMANDS[SUB]``;
- ``python3 path/script.py``: the script (itself a dep) and its imports.

A dep covers a file when it is the file or a folder above it. tests/test_dvc_hygiene.py fails when one is missed.
"""
from __future__ import annotations

import ast
import shlex
import sys
from pathlib import Path

import yaml

from svcore.codegraph import PACKAGES, ROOT, closure, imported_names  # noqa: F401 (PACKAGES: named above)


def command_entries(cmd: str, root: Path = ROOT) -> tuple[dict[str, ast.AST | None], set[Path]]:
    """Entry modules (name -> AST scope or None) and entry script files of a stage command (``&&`` chains)."""
    entries: dict[str, ast.AST | None] = {}
    scripts: set[Path] = set()
    for part in cmd.split("&&"):
        words = shlex.split(part)
        if not words:
            continue
        if words[0] == "svgen" and len(words) > 1:
            from pipeline.cli import COMMANDS

            entries.setdefault("pipeline.cli", None)
            entries[COMMANDS[words[1]].split(":")[0]] = None
        elif words[0] == "svtrain" and len(words) > 1:
            from train.cli import COMMANDS as SVTRAIN_COMMANDS

            entries.setdefault("train.cli", None)
            entries[SVTRAIN_COMMANDS[words[1]].split(":")[0]] = None
        elif words[0].startswith("python") and len(words) > 1 and words[1].endswith(".py"):
            script = root / words[1]
            scripts.add(script)
            entries[f"__script__:{words[1]}"] = ast.parse(script.read_text(), str(script))
        else:
            raise ValueError(f"stage command {part.strip()!r}: unknown entry point (add it to scripts/stage_deps.py)")
    return entries, scripts


def stage_files(cmd: str, root: Path = ROOT) -> set[Path]:
    """Every project file (and entry script) a stage command imports."""
    entries, scripts = command_entries(cmd, root)
    files = set(scripts)
    for name, tree in entries.items():
        if name.startswith("__script__:"):
            script = root / name.split(":", 1)[1]
            names = imported_names(tree, script.stem, script, root)
            files |= closure({n: None for n in names}, root)
        else:
            files |= closure({name: tree}, root)
    return files


def covered(path: Path, deps: list[str], root: Path = ROOT) -> bool:
    """Whether a dep path (file, or folder above the file) covers ``path``."""
    rel = path.relative_to(root)
    for d in deps:
        dp = Path(d.rstrip("/"))
        if rel == dp or dp in rel.parents:
            return True
    return False


def uncovered(dvc_yaml: Path = ROOT / "dvc.yaml", root: Path = ROOT) -> dict[str, list[str]]:
    """stage -> the imported project files (relative paths) that none of its deps covers."""
    stages = yaml.safe_load(dvc_yaml.read_text())["stages"]
    out = {}
    for name, st in stages.items():
        deps = [d if isinstance(d, str) else next(iter(d)) for d in st.get("deps", [])]
        miss = sorted(str(p.relative_to(root)) for p in stage_files(st["cmd"], root) if not covered(p, deps, root))
        out[name] = miss
    return out


def main() -> int:
    bad = 0
    for stage, miss in uncovered().items():
        print(f"{stage}: " + (", ".join(miss) if miss else "complete"))
        bad += bool(miss)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
