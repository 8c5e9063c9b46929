"""The layout shows the architecture (issues #26, #41): no import circles among the project's modules, and packages
import only downward, svcore < materials < storage < pipeline < train, with no exception; train takes nothing from
pipeline (a renders store's reader and a view's transform are storage's).

The graph is read with ``ast`` from the source (every import, at module level or inside a function: a lazy
import still ties two modules together), so the test runs in milliseconds and imports nothing.
"""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the project's packages, lowest first: a module may import its own package and those before it.
LAYERS = ("svcore", "materials", "storage", "pipeline", "train")
#: upward or sideways edges that are allowed, each with its reason: none (#41 removed the last one).
ALLOWED: set[tuple[str, str]] = set()
#: what train may import from pipeline: nothing (the renders store's reader is storage's, #41).
TRAIN_FROM_PIPELINE: set[str] = set()


def modules(root: Path = ROOT) -> dict[str, Path]:
    """Dotted name -> file of every module of the project's packages (a package's ``__init__`` by its name)."""
    out = {}
    for pkg in LAYERS:
        for p in sorted((root / pkg).rglob("*.py")):
            parts = list(p.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = p
    return out


def _targets(name: str, node: ast.AST, mods: dict[str, Path]) -> set[str]:
    """The project modules an import statement in module ``name`` names (relative imports resolved)."""
    is_pkg = mods[name].name == "__init__.py"
    if isinstance(node, ast.Import):
        bases = [a.name for a in node.names]
        froms: list[str] = []
    else:
        base = node.module or ""
        if node.level:
            pkg = name.split(".") if is_pkg else name.split(".")[:-1]
            pkg = pkg[:len(pkg) - (node.level - 1)]
            base = ".".join([*pkg, *([base] if base else [])])
        bases = [base]
        froms = [f"{base}.{a.name}" for a in node.names]
    def module_of(dotted: str) -> str:  # the longest prefix that is a project module ("" if none)
        while dotted and dotted not in mods:
            dotted = dotted.rpartition(".")[0]
        return dotted

    sub = {f for f in froms if f in mods}  # `from pkg import module`: an edge to that module
    out = sub | {module_of(b) for b in bases if not froms or len(sub) < len(froms)}
    return out - {name, ""}


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the project modules it imports (anywhere in its source)."""
    mods = modules(root)
    graph = {}
    for name, path in mods.items():
        edges: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                edges |= _targets(name, node, mods)
        graph[name] = edges
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import circles: strongly connected components of more than one module (Tarjan), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def layer_violations(graph: dict[str, set[str]]) -> list[str]:
    """Edges that go up the layers (or from train into pipeline beyond TRAIN_FROM_PIPELINE), minus ALLOWED."""
    rank = {p: i for i, p in enumerate(LAYERS)}
    bad = []
    for a, targets in sorted(graph.items()):
        for b in sorted(targets):
            pa, pb = a.split(".")[0], b.split(".")[0]
            if (a, b) in ALLOWED:
                continue
            if rank[pb] > rank[pa]:
                bad.append(f"{a} -> {b} (imports upward: {pa} < {pb})")
            elif pa == "train" and pb == "pipeline" and b not in TRAIN_FROM_PIPELINE:
                bad.append(f"{a} -> {b} (train takes from pipeline only {sorted(TRAIN_FROM_PIPELINE)})")
    return bad


def test_no_import_circles():
    found = cycles(import_graph())
    assert not found, "import circles: " + "; ".join(" <-> ".join(c) for c in found)


def test_packages_import_only_downward():
    bad = layer_violations(import_graph())
    assert not bad, "\n".join(bad)


def test_the_graph_sees_lazy_and_relative_imports():
    """The reader itself: a function-level relative import is an edge (else a lazy import would hide a circle)."""
    g = import_graph()
    assert "storage.local" in g["storage.store"] and "storage.card" in g["storage.local"]
    assert "pipeline.render.stage" in g["pipeline.commands.render"]  # `from ..render.stage import` in a function
    assert g["svcore.errors"] == set()


def test_pipeline_top_level_stays_small():
    """pipeline/ holds the stages and their shared config and CLI; execution, commands, importer and renderer are
    subpackages, storage its own package (#26: about 12 modules at the top)."""
    top = [p.name for p in (ROOT / "pipeline").glob("*.py") if p.name != "__init__.py"]
    assert len(top) <= 13, sorted(top)
