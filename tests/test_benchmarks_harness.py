"""The benchmark harness: every script uses it and nothing else for paths (no sys.path edits, no imports from
tests/), results carry one machine-info key set, and the committed results still rebuild the charts."""
from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"
# the runnable benchmarks (a __main__ block); modules they import (harness, charts_*, ablation_effects) are not scripts
SCRIPTS = sorted(p for p in BENCH.glob("*.py") if p.name != "harness.py" and "__main__" in p.read_text())
MACHINE_KEYS = {"platform", "machine", "cpu", "cpus", "python", "versions", "threads", "loadavg_1min", "code"}


@pytest.fixture(scope="module")
def harness():
    sys.path.insert(0, str(BENCH))
    try:
        import harness

        yield harness
    finally:
        sys.path.remove(str(BENCH))


def _imports(path: Path) -> set[str]:
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module.split(".")[0])
    return out


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_script_uses_the_harness_only(script):
    src = script.read_text()
    assert "harness" in _imports(script), f"{script.name} does not import benchmarks/harness.py"
    assert "sys.path" not in src, f"{script.name} edits sys.path (the harness docstring says why not)"
    assert not _imports(script) & {"conftest", "tests", "render_helpers"}, f"{script.name} imports from tests/"


def test_results_carry_machine_info_and_note(harness, tmp_path):
    path = harness.write_results(tmp_path / "r.json", {"figure": 1.0}, note="shared machine")
    d = json.loads(path.read_text())
    assert d["figure"] == 1.0 and d["note"] == "shared machine" and d["command"].startswith("python3 ")
    assert set(d["machine"]) == MACHINE_KEYS
    assert d["machine"]["versions"]["numpy"] == __import__("numpy").__version__
    assert d["machine"]["code"]["path"] == "."  # the measured code is this checkout (relative to the repository)


def test_timed_takes_medians(harness):
    calls = iter([0.0, 0.05, 0.0])

    def f():
        import time

        time.sleep(next(calls))
        return "done"

    out, cpu, wall = harness.timed(f, reps=3)
    assert out == "done" and wall < 0.04 and cpu >= 0.0  # the one slow call is not the median


def test_charts_rebuild_from_committed_results(tmp_path):
    """benchmarks/charts reads every committed results file (old machine keys included) without a benchmark."""
    r = subprocess.run([sys.executable, str(BENCH / "charts"), "--out", str(tmp_path)], cwd=tmp_path,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    for name in ("chart_render", "chart_training", "chart_scaleout", "chart_agreement"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000, (name, r.stdout)
    assert (tmp_path / "chart_render.csv").read_text().startswith("res,light,sampler,spp")


def _strings(obj):
    """Every string of a JSON value (keys and values)."""
    if isinstance(obj, str):
        yield obj
    elif isinstance(obj, dict):
        for k, v in obj.items():
            yield k
            yield from _strings(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from _strings(v)


def test_committed_results_hold_no_absolute_path(harness):
    """Results files record paths relative to the repository (#26): an absolute path means nothing elsewhere and
    shows one machine's layout."""
    found = [f"{p.relative_to(ROOT)}: {m}" for p in sorted((BENCH / "results").rglob("*.json"))
             for s in _strings(json.loads(p.read_text())) for m in harness.ABSOLUTE_PATH.findall(s)]
    assert not found, "\n".join(found[:20])


def test_results_writer_makes_paths_relative(harness, tmp_path):
    """The writer rewrites what a script hands it: a store under the repository, a temporary folder in a command
    line and the measured checkout; URLs and units stay as they are."""
    out = harness.write_results(tmp_path / "r.json", {
        "store": str(harness.ROOT / "data" / "renders.zarr"), "url": "s3://bucket/a/b.zarr", "unit": "s/view",
        "command": f"svtrain fit --out {tmp_path}/run --store ./data/x.zarr"})
    res = json.loads(out.read_text())
    assert res["store"] == "data/renders.zarr" and res["url"] == "s3://bucket/a/b.zarr" and res["unit"] == "s/view"
    assert res["machine"]["code"]["path"] == "."
    assert "--store ./data/x.zarr" in res["command"] and str(tmp_path) not in res["command"]
    assert not [m for s in _strings(res) for m in harness.ABSOLUTE_PATH.findall(s)]
