"""The project's import graph, read from the source with ``ast`` (nothing is imported): which project modules a
module can run, directly or through other project modules.

Imports inside functions count (the CLIs import their stage modules lazily), and so do ``importlib.import_module``
calls whose name is a literal or an f-string over ``__name__``/``__package__`` (a name with an unknown part, such as
the loop over ``materials/classes``, counts as importing every module under its known prefix). Two users:
``scripts/stage_deps.py`` checks that each DVC stage's deps cover the files its command can import, and
:func:`svcore.versions.closure_digest` names the code a store was written by with exactly those files, so a change
to other code (training, the gallery) changes no byte of a store and no DVC hash.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

#: the project's root (the folder holding its packages)
ROOT = Path(__file__).resolve().parents[1]
#: the packages whose modules are followed; imports of anything else (numpy, zarr, ...) end the walk
PACKAGES = ("svcore", "storage", "pipeline", "materials", "train")
#: a line that starts an import statement (at any indentation: imports inside functions count), through a
#: parenthesised name list
_IMPORT_LINE = re.compile(r"^[ \t]*(?:from[ \t]+\.*[\w.]*[ \t]+import[ \t]*(?:\([^)]*\)|[^\n]*)|import[ \t]+[^\n]*)",
                          re.M)
#: an ``import_module(...)`` call (its argument without nested calls)
_IMPORT_MODULE = re.compile(r"import_module\((?:[^()\n]|\([^()\n]*\))*\)")


def module_file(name: str, root: Path = ROOT) -> Path | None:
    """The source file of project module ``name`` (a package's __init__.py), or None when it is not one."""
    if name.split(".")[0] not in PACKAGES:
        return None
    base = root.joinpath(*name.split("."))
    for p in (base.with_suffix(".py"), base / "__init__.py"):
        if p.is_file():
            return p
    return None


def _fstring_prefix(node: ast.JoinedStr, name: str, package: str) -> tuple[str, bool]:
    """The literal text of an f-string with __name__/__package__ substituted, and whether it is complete."""
    text = ""
    for part in node.values:
        if isinstance(part, ast.Constant):
            text += str(part.value)
        elif isinstance(part, ast.FormattedValue) and isinstance(part.value, ast.Name) \
                and part.value.id in ("__name__", "__package__"):
            text += name if part.value.id == "__name__" else package
        else:
            return text, False
    return text, True


def _under(prefix: str, root: Path) -> list[str]:
    """Every project module whose dotted name starts with ``prefix`` (``materials.classes.``)."""
    pkg = prefix.rstrip(".")
    folder = root.joinpath(*pkg.split("."))
    if not folder.is_dir():
        return [pkg] if module_file(pkg, root) else []
    return [pkg] + [".".join(p.relative_to(root).with_suffix("").parts) for p in sorted(folder.rglob("*.py"))
                    if p.name != "__init__.py"]


def imported_names(tree: ast.AST, name: str, path: Path, root: Path = ROOT) -> set[str]:
    """Dotted names a module's code may import (anywhere in it), relative imports resolved."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.add(mod)
            out.update(f"{mod}.{a.name}" for a in node.names)  # `from pkg import submodule`
        elif isinstance(node, ast.Call) and node.args and (
                (isinstance(node.func, ast.Attribute) and node.func.attr == "import_module")
                or (isinstance(node.func, ast.Name) and node.func.id == "import_module")):
            arg = node.args[0]
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                out.add(arg.value)
            elif isinstance(arg, ast.JoinedStr):
                text, complete = _fstring_prefix(arg, name, package)
                out.update([text] if complete else _under(text.rpartition(".")[0] + ".", root))
    return out


def import_tree(path: Path) -> ast.Module:
    """The import statements and ``import_module`` calls of a module, as an AST that :func:`imported_names` reads.

    Found in the text and parsed one by one: a store writer computes its code's closure on every run
    (:func:`svcore.versions.closure_digest`), and parsing every file whole took about 1 s for 60 modules on a busy
    2-core machine. A statement the text pattern cuts short (a backslash continuation, say) does not parse: then
    the whole file is parsed, so nothing is ever missed; text that reads as an import inside a string counts
    (an edge too many, never one too few). tests/test_dvc_hygiene.py holds both ways equal on every module.
    """
    text = path.read_text()
    body: list[ast.stmt] = []
    try:
        for m in _IMPORT_LINE.finditer(text):
            body += ast.parse(m.group(0).strip()).body
        body += [ast.Expr(ast.parse(m.group(0), mode="eval").body) for m in _IMPORT_MODULE.finditer(text)]
    except SyntaxError:
        return ast.parse(text, str(path))
    return ast.Module(body=body, type_ignores=[])


def closure(start: dict[str, ast.AST | None], root: Path = ROOT) -> set[Path]:
    """Project source files reached from ``start`` (dotted name -> the AST to scan instead of the whole module's,
    or None), parent packages' __init__.py included."""
    seen: set[str] = set()
    files: set[Path] = set()
    todo = list(start.items())
    while todo:
        name, tree = todo.pop()
        if name in seen and tree is None:
            continue
        path = module_file(name, root)
        if path is None:
            continue
        seen.add(name)
        files.add(path)
        parts = name.split(".")
        todo += [(".".join(parts[:k]), None) for k in range(1, len(parts))]  # parents run their __init__
        tree = tree if tree is not None else import_tree(path)
        todo += [(n, None) for n in imported_names(tree, name, path, root) if n not in seen]
    return files
