"""docs/ENVIRONMENT.md names every environment variable the code reads, and the shell completion it documents works;
the README's first hour runs as written."""
from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("materials", "pipeline", "svcore", "train")


def _is_environ(node: ast.AST) -> bool:
    return isinstance(node, ast.Attribute) and node.attr == "environ" and isinstance(node.value, ast.Name) \
        and node.value.id == "os"


def env_vars_read() -> set[str]:
    """Names in ``os.environ.get(X)``, ``os.environ[X]``, ``os.getenv(X)``, ``X in os.environ`` across the packages;
    X a string or a module-level string constant (``SCHEDULER_ENV = "..."``, also reached as ``module.NAME``)."""
    trees = {p: ast.parse(p.read_text()) for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")}
    consts = {t.id: n.value.value for tree in trees.values() for n in tree.body if isinstance(n, ast.Assign)
              for t in n.targets if isinstance(t, ast.Name) and isinstance(n.value, ast.Constant)
              and isinstance(n.value.value, str)}
    consts.update({t.id: v.value for tree in trees.values() for n in tree.body if isinstance(n, ast.Assign)
                   and isinstance(n.targets[0], ast.Tuple) and isinstance(n.value, ast.Tuple)
                   for t, v in zip(n.targets[0].elts, n.value.elts)
                   if isinstance(t, ast.Name) and isinstance(v, ast.Constant) and isinstance(v.value, str)})

    def name(arg: ast.AST) -> str | None:
        if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
            return arg.value
        key = arg.id if isinstance(arg, ast.Name) else arg.attr if isinstance(arg, ast.Attribute) else None
        return consts.get(key)

    found = set()
    for tree in trees.values():
        for n in ast.walk(tree):
            arg = None
            if isinstance(n, ast.Call) and n.args:
                f = n.func
                if isinstance(f, ast.Attribute) and f.attr in ("get", "pop", "setdefault") and _is_environ(f.value):
                    arg = n.args[0]
                elif isinstance(f, ast.Attribute) and f.attr == "getenv":
                    arg = n.args[0]
            elif isinstance(n, ast.Subscript) and _is_environ(n.value):
                arg = n.slice
            elif isinstance(n, ast.Compare) and any(_is_environ(c) for c in n.comparators):
                arg = n.left
            if arg is not None and (v := name(arg)):
                found.add(v)
    return found


def test_every_environment_variable_the_code_reads_is_documented():
    """docs/ENVIRONMENT.md (the README links it) names each variable the packages read, as `NAME`."""
    readme = (ROOT / "docs" / "ENVIRONMENT.md").read_text()
    assert "(docs/ENVIRONMENT.md)" in (ROOT / "README.md").read_text()
    found = env_vars_read()
    assert {"SVGEN_DEBUG", "SVGEN_NO_PROGRESS", "SVGEN_MI_VARIANT", "DRJIT_LIBLLVM_PATH",
            "DASK_SCHEDULER_ADDRESS"} <= found  # the scan itself sees the known ones (constants included)
    missing = sorted(v for v in found if not v.startswith("SVGEN_TEST_")  # test hooks: named as SVGEN_TEST_*
                     and not re.search(rf"`{v}(?![A-Za-z0-9_])", readme))
    assert not missing, f"docs/ENVIRONMENT.md does not document {missing}"


def test_shell_completion_as_the_readme_says():
    env = {**os.environ, "_SVGEN_COMPLETE": "bash_source"}
    r = subprocess.run([sys.executable, "-c", "from pipeline.cli import main; main()"], env=env, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0 and "_svgen_completion" in r.stdout, r.stderr
    env = {**os.environ, "_SVGEN_COMPLETE": "bash_complete", "COMP_WORDS": "svgen ren", "COMP_CWORD": "1"}
    r = subprocess.run([sys.executable, "-c", "from pipeline.cli import main; main()"], env=env, capture_output=True,
                       text=True, timeout=120)
    assert "plain,render" in r.stdout.splitlines(), r.stdout  # bash_complete: "type,value" per candidate


# -- the conventions live in the repository (issue 25, item 14) -------------------------------------------------------
def test_docs_point_to_the_conventions_inside_the_repository():
    """A clone has no ../shared: README and docs name docs/CONVENTIONS.md, no .md outside the repository, and every
    docs/*.md they name exists."""
    import math

    from materials import capture

    docs = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    for doc in docs:
        text = doc.read_text()
        assert "DESIGN.md" not in text, doc.name
        for ref in set(re.findall(r"[\w./-]+\.md\b", text)):
            inside = (doc.parent / ref).resolve()  # a page in docs/ links ../train/...: inside, and it must exist
            assert not ref.startswith("../") or inside.is_relative_to(ROOT) and inside.is_file(), \
                f"{doc.name} names {ref}, outside the repository"
            if ref.startswith("docs/"):
                assert (ROOT / ref).is_file(), f"{doc.name} names {ref}, which does not exist"
    conv = (ROOT / "docs" / "CONVENTIONS.md").read_text()
    assert "`docs/CONVENTIONS.md`" in (ROOT / "README.md").read_text()
    for section in ("## The BRDF", "## Maps", "## The capture scene", "## The rendering loss"):
        assert section in conv, section
    # the numbers it states are the code's
    assert f"D = 1 / tan {capture.FOV_DEG / 2:g}° ≈ {capture.CAMERA_DISTANCE:.4f}" in conv
    assert f"{capture.PLANE_SIZE:g} × {capture.PLANE_SIZE:g} at z = 0" in conv
    assert math.isclose(capture.CAMERA_DISTANCE, 2.1445, abs_tol=5e-5)


# -- the README's first hour (issue 25) --------------------------------------------------------------------------------
def first_hour() -> tuple[list[str], str]:
    """(the commands of the README's first-hour block, the python block that follows it)."""
    text = (ROOT / "README.md").read_text()
    m = re.search(r"<!-- first-hour:.*?-->\s*```bash\n(.*?)```", text, re.S)
    p = re.search(r"<!-- first-hour-python:.*?-->\s*```python\n(.*?)```", text, re.S)
    assert m and p, "README.md lost its first-hour blocks"
    return [line.split("  #")[0].strip() for line in m.group(1).splitlines() if line.strip()], p.group(1)


def test_the_first_hour_runs_as_written(tmp_path):
    """Every command of the README's first hour, in an empty folder, in order: each exits 0 and leaves what the
    README says it leaves; then the xarray block."""
    import shlex

    commands, python = first_hour()
    assert commands[0] == "bash scripts/setup.sh" and (ROOT / "scripts" / "setup.sh").is_file()
    tools = {"svgen": [sys.executable, "-c", "from pipeline.cli import main; main()"],
             "svtrain": [sys.executable, "-c", "from train.cli import main; main()"]}
    env = {**os.environ, "PYTHONPATH": str(ROOT), "SVGEN_NO_PROGRESS": "1"}
    for cmd in commands[1:]:
        argv = shlex.split(cmd)
        assert argv[0] in tools, cmd
        r = subprocess.run(tools[argv[0]] + argv[1:], cwd=tmp_path, env=env, capture_output=True, text=True)
        assert r.returncode == 0, (cmd, r.stderr[-2000:])
    for path in ("data/renders.zarr/README.md", "runs/gallery/index.html", "runs/first/model.pt",
                 "runs/first/run.json", "runs/photo_maps/diffuse.exr", "runs/photo_maps/rerender.png"):
        assert (tmp_path / path).is_file(), path
    r = subprocess.run([sys.executable, "-W", "ignore", "-c", python], cwd=tmp_path, env=env, capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "svgen render variants.zarr OUT" in r.stdout and (tmp_path / "runs/renders.nc").is_file()
