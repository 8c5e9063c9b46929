"""Benchmarks that say when they are stale (#24): results files record the digest of the code they measured,
benchmarks/stale.py flags those whose code changed, and re-measuring flags a regression above 20 %."""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"


@pytest.fixture(scope="module")
def bench():
    sys.path.insert(0, str(BENCH))
    try:
        import freshness
        import harness

        yield harness, freshness
    finally:
        sys.path.remove(str(BENCH))


def _tree(root: Path) -> Path:
    """A tiny project: a package and a benchmark script."""
    (root / "pkg").mkdir(parents=True)
    (root / "pkg" / "__init__.py").write_text("X = 1\n")
    (root / "benchmarks").mkdir()
    (root / "benchmarks" / "bench_x.py").write_text("import pkg\n")
    return root


def test_digest_scope_and_staleness_after_an_edit(bench, tmp_path):
    _, fr = bench
    root = _tree(tmp_path)
    rec = fr.measured_code(root, script=root / "benchmarks" / "bench_x.py", code=["pkg"], modules={})
    assert set(rec) == {"benchmarks/bench_x.py", "pkg/"}
    results = {"variants_per_s": 10.0, "code_digest": rec}
    assert fr.freshness(results, root).state == "fresh"
    (root / "pkg" / "other.py").write_text("Y = 2\n")  # an edit of the measured package
    f = fr.freshness(results, root)
    assert f.state == "stale" and f.changed == ["pkg/"]
    assert fr.freshness({"variants_per_s": 10.0}, root).state == "unknown"  # written before digests


def test_written_results_record_the_measured_code(bench, tmp_path):
    """A results file written through the harness is fresh on the code that wrote it and stale once a recorded
    digest differs (what an edit of that code does), in its own key and in an update_results entry."""
    harness, fr = bench
    import storage  # noqa: F401  (a project package the "measurement" imported)

    path = harness.write_results(tmp_path / "r.json", {"wall_s": 1.0}, code=["pipeline"])
    data = json.loads(path.read_text())
    assert {"storage/", "pipeline/"} <= set(data["code_digest"])
    assert not any(k.startswith("/") for k in data["code_digest"])
    assert fr.freshness(data, ROOT).state == "fresh"
    data["code_digest"]["pipeline/"] = "0" * 64
    f = fr.freshness(data, ROOT)
    assert f.state == "stale" and f.changed == ["pipeline/"]

    shared = harness.update_results(tmp_path / "s.json", "entry", {"wall_s": 1.0})
    data = json.loads(shared.read_text())
    assert fr.freshness(data, ROOT).state == "fresh"
    data["entry"]["code_digest"]["storage/"] = "0" * 64
    assert fr.freshness(data, ROOT).changed == ["entry: storage/"]


def test_stale_script_lists_stale_and_unknown(bench, tmp_path):
    harness, _ = bench
    fresh = harness.write_results(tmp_path / "fresh.json", {"views_per_s": 50.0}, code=["storage"])
    stale = json.loads(fresh.read_text())
    stale["code_digest"]["storage/"] = "0" * 64
    (tmp_path / "stale.json").write_text(json.dumps(stale))
    (tmp_path / "old.json").write_text(json.dumps({"wall_s": 3.0}))
    r = subprocess.run([sys.executable, str(BENCH / "stale.py"), "--results", str(tmp_path), "--check"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 1, r.stderr
    lines = r.stdout.splitlines()
    assert any(ln.startswith("stale") and "stale.json" in ln and "storage/" in ln for ln in lines), r.stdout
    assert any(ln.startswith("unknown") and "old.json" in ln for ln in lines), r.stdout
    assert "views_per_s=50" in r.stdout and not any("fresh.json" in ln for ln in lines)
    assert "1 stale, 1 unknown, 1 fresh of 3" in r.stdout
    (tmp_path / "stale.json").unlink()
    r = subprocess.run([sys.executable, str(BENCH / "stale.py"), "--results", str(tmp_path), "--check", "--all"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "fresh   fresh.json" in r.stdout, r.stdout


@pytest.mark.parametrize("name,before,after,regression", [
    ("variants_per_s", 100.0, 79.0, True),     # a rate: higher is better, -21 %
    ("variants_per_s", 100.0, 81.0, False),    # -19 %
    ("variants_per_s", 100.0, 200.0, False),   # faster
    ("cpu_s_per_view", 1.0, 1.21, True),       # a cost: lower is better, +21 %
    ("cpu_s_per_view", 1.0, 1.19, False),
    ("bytes_per_view", 100.0, 50.0, False),
    ("levels", 7.0, 2.0, False),               # the name does not say: shown, never flagged
])
def test_regression_above_20_percent_is_flagged(bench, tmp_path, capsys, name, before, after, regression):
    harness, _ = bench
    path = tmp_path / "r.json"
    harness.write_results(path, {name: before})
    assert "changes" not in json.loads(path.read_text())  # nothing to compare the first measurement with
    harness.write_results(path, {name: after})
    changes = json.loads(path.read_text())["changes"]
    assert changes["regressions"] == ([name] if regression else [])
    err = capsys.readouterr().err
    assert (f"{name}: {before:.6g} -> {after:.6g}" in err) and (("REGRESSION" in err) == regression), err


def test_nested_figures_and_update_results_compare_against_the_same_entry(bench, tmp_path):
    harness, _ = bench
    path = tmp_path / "s.json"
    harness.update_results(path, "a", {"stage": {"wall_s": 10.0}})
    harness.update_results(path, "b", {"stage": {"wall_s": 99.0}})
    harness.update_results(path, "a", {"stage": {"wall_s": 13.0}})
    data = json.loads(path.read_text())
    assert data["a"]["changes"]["regressions"] == ["stage.wall_s"]  # against a's 10 s, not b's 99 s
    assert "changes" not in data["b"]


def test_direction_from_the_name(bench):
    _, fr = bench
    assert [fr.direction(n) for n in ("variants_per_s", "it_per_s", "speedup_vs_paper", "peak_rss_mb",
                                      "render.wall_s", "rel_rmse_vs_reference", "views")] == [1, 1, 1, -1, -1, -1, 0]


# -- quoted figures say which code they belong to (#41) ---------------------------------------------------------
def _quoting_tree(root: Path, fr, page: str) -> Path:
    """A tiny project whose docs/PAGE.md holds ``page`` and whose results folder holds r.json, fresh (measured on
    the tree's own package ``pkg``)."""
    _tree(root)
    (root / "docs").mkdir()
    (root / "docs" / "PAGE.md").write_text(page)
    results = root / "benchmarks" / "results"
    results.mkdir()
    rec = fr.measured_code(root, script=root / "benchmarks" / "bench_x.py", code=["pkg"], modules={})
    (results / "r.json").write_text(json.dumps({"views_per_s": 50.0, "code_digest": rec}))
    return root


def _quoted_check(root: Path, capsys) -> tuple[int, str]:
    """``stale.py --check --quoted --root ROOT`` in this process: (exit code, output)."""
    import stale

    code = stale.main(["--check", "--quoted", "--root", str(root)])
    return code, capsys.readouterr().out


@pytest.mark.parametrize("page,undated", [
    ("Views: 50/s (`benchmarks/results/r.json`).\n", True),
    ("Views: 50/s (`results/r.json`, 2026-11-26, commit 3f32302).\n", False),
    ("Views: 50/s\n(r.json of 2026-11-26,\ncommit `3f32302`).\n", False),  # anywhere in its paragraph
    ("| views | 50/s | `r.json` 2026-11-26 |\n| commit 3f32302 | | |\n", True),  # a table row is its own block
    ("Views: 50/s (r.json, commit 3f32302).\n", True),  # the date is missing
    ("Views: 50/s (r.json, 2026-11-26, 3f32302).\n", True),  # "commit" is missing
    ("`results/q.json` (2026-11-26, commit 3f32302) and `results/r.json`.\n", True),  # another file's stamp
    ("```\npython3 bench_x.py --out results/r.json\n```\n", False),  # a command in code is not a quote
    ("The run writes `DIR/r.json` and `rr.json`.\n", False),  # another folder's r.json, another name
])
def test_a_stale_quote_needs_its_date_and_commit(bench, tmp_path, capsys, page, undated):
    """stale.py --check --quoted passes while the quoted file is fresh; once its code changes, it fails on each
    quote that does not give the date and commit of the measurement, and names the page and line."""
    _, fr = bench
    root = _quoting_tree(tmp_path, fr, page)
    code, out = _quoted_check(root, capsys)
    assert code == 0 and "0 stale, 0 unknown, 1 fresh of 1 quoted" in out or "DIR/" in page or "```" in page, out
    (root / "pkg" / "__init__.py").write_text("X = 2\n")  # the measured code changes: r.json is stale
    code, out = _quoted_check(root, capsys)
    assert code == (1 if undated else 0), out
    assert ("docs/PAGE.md:1: NO DATE AND COMMIT" in out) == undated, out


def test_every_quoted_stale_figure_in_the_docs_gives_its_date_and_commit():
    """The README's test command runs this: each quote in README.md and docs/*.md of a results file whose code
    changed since (or that records none) says when and on which commit it was measured (issue #41)."""
    r = subprocess.run([sys.executable, str(BENCH / "stale.py"), "--check", "--quoted"], capture_output=True,
                       text=True, timeout=300)
    undated = [ln.strip() for ln in r.stdout.splitlines() if ln.endswith("NO DATE AND COMMIT")]
    assert r.returncode == 0 and not undated, (
        "quotes of stale results files without the date and commit of the measurement (add them beside the quote, "
        f"e.g. '2026-11-26, commit 3f32302', or measure again): {undated}\n{r.stdout[-2000:]}{r.stderr[-2000:]}")
    found = re.search(r"of (\d+) quoted results files", r.stdout)
    # the scan found the pages' quotes: 63 in #41, 25 once the finished experiments moved to experiments/, 18 once
    # the one-off measurements followed them, 14 once the width sweep and the worker-environment comparison did, 13
    # once the store codec measurement did
    assert found and int(found.group(1)) >= 12, r.stdout[-2000:]
