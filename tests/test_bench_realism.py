"""benchmarks/bench_realism.py: refuses a missing reference folder in one line, keeps the other keys of the results
file it shares, writes a library other than the default only to a file of its own, and on the real reference folder
(skipped, saying so, when it is absent) writes every statistic."""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "bench_realism.py"


@pytest.fixture(scope="module")
def reference_dir() -> Path:
    """The shared real materials: SVGEN_REFERENCE_DIR, else ../shared/materials-cc0 beside the checkout root."""
    d = Path(os.environ.get("SVGEN_REFERENCE_DIR") or ROOT.parent / "shared" / "materials-cc0")
    if not d.is_dir():
        pytest.skip(f"no reference materials at {d} (set SVGEN_REFERENCE_DIR to the materials-cc0 folder)")
    return d


def bench(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True,
                          timeout=600)


def test_missing_reference_folder_is_one_line(tmp_path):
    r = bench(tmp_path / "absent", "--out", tmp_path / "r.json")
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.count("\n") == 1 and "no reference folder at" in r.stderr
    assert not (tmp_path / "r.json").exists()


def test_update_results_keeps_other_keys(tmp_path):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        from harness import update_results
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    p = tmp_path / "realism.json"
    p.write_text(json.dumps({"sim_to_real": {"x": 1}}))
    update_results(p, "statistics", {"y": 2}, note="n")
    d = json.loads(p.read_text())
    assert d["sim_to_real"] == {"x": 1} and d["statistics"]["y"] == 2 and d["statistics"]["note"] == "n"
    assert not Path(d["statistics"]["machine"]["code"]["path"]).is_absolute()


def test_bench_on_the_reference_with_a_library_setting(reference_dir, tmp_path):
    """Every statistic on the real reference (one run: the import of the 32 materials is most of it). ``--set``
    changes the library measured (a strong band of relief at 24 cycles per 64-pixel map puts most slope power in the
    finest octave, 16-32 cycles; the default library: 0.36), written to the ``--out`` file with its other keys kept."""
    out = tmp_path / "realism.json"
    out.write_text(json.dumps({"sim_to_real": {"kept": True}}))
    r = bench(reference_dir, "--per-preset", 1, "--size", 64, "--splits", 2, "--out", out,
              "--chart", tmp_path / "c.png", "--set", "relief=0.5", "--set", "relief_cycles=24")
    assert r.returncode == 0, r.stderr
    d = json.loads(out.read_text())
    assert d["sim_to_real"] == {"kept": True}
    res = d["statistics"]
    rep = res["report"]
    n = sum(1 for p in reference_dir.iterdir() if p.is_dir())
    assert rep["reference"]["materials"] == n and rep["stores"][0]["materials"] > 0
    for k, v in rep["distances"].items():
        assert math.isfinite(v["noise_floor"]) and all(math.isfinite(x) for x in v["to_reference"].values()), k
    assert sum(rep["octave_shares"][rep["reference"]["name"]]) == pytest.approx(1.0)
    assert "/" not in res["reference_folder"][:1]  # relative, no absolute path in results
    assert (tmp_path / "c.png").read_bytes()[:4] == b"\x89PNG"
    assert res["library"]["settings"] == {"relief": 0.5, "relief_cycles": 24}
    shares = rep["octave_shares"]["svgen default library"]
    assert shares[rep["octaves"].index([16, 32])] > 0.6, shares


@pytest.mark.parametrize("setting", ["nosuchkey=1", "relief", "relief=-1"])
def test_a_bad_library_setting_is_one_line(tmp_path, setting):
    r = bench(tmp_path, "--set", setting, "--out", tmp_path / "r.json")
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("bench_realism: ")
    assert not (tmp_path / "r.json").exists()


def test_a_library_setting_without_its_own_file_is_refused(tmp_path):
    """The maintained results file holds the default library only: ``--set`` without ``--out`` is refused in one
    line before anything runs, and the committed file is untouched."""
    maintained = ROOT / "benchmarks" / "results" / "realism.json"
    before = maintained.read_bytes()
    r = bench(tmp_path, "--set", "relief=0.5")
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.count("\n") == 1 and "--out" in r.stderr
    assert maintained.read_bytes() == before
