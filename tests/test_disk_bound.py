"""A run whose output cannot fit on the disk is refused up front, with the estimate and the free space (#24).

The estimates are arithmetic, so a count above what the real free space holds is refused before anything is
written: the test needs no small disk. The count is chosen from the file system's real free space so that the
expected size (raw / EXPECTED_COMPRESSION) exceeds it while the old best-case floor (raw / 64) did not: the
refusal comes from the estimate, not from an astronomical count."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from pipeline.config import SampleConfig
from pipeline.sample import run_sample
from storage import bounds
from storage.svbrdf_store import array_specs
from svcore.config import build
from svcore.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    d = tmp_path_factory.mktemp("disk")
    return run_sample(d / "v.zarr", build(SampleConfig, "tiny", presets=("paint/glossy_red",), per_preset=2),
                      workers=0)


def _too_many(out: Path, per: int) -> int:
    """A sample count whose expected store is 1.5x the free space of ``out``'s file system."""
    return int(1.5 * bounds.free_disk(out) * bounds.EXPECTED_COMPRESSION / per) + 1


def test_blend_beyond_the_free_disk_is_refused_in_one_line_and_writes_nothing(variants, tmp_path):
    out = tmp_path / "out" / "b.zarr"
    per = bounds.sample_bytes(array_specs("blends", 64))
    n = _too_many(tmp_path, per)
    assert n * per / 64 < bounds.free_disk(tmp_path)  # the best-case floor alone would have let it start
    env = {**os.environ, "PYTHONPATH": str(ROOT), "SVGEN_NO_PROGRESS": "1"}
    r = subprocess.run([sys.executable, "-c", "from pipeline.cli import main; main()", "blend", str(variants),
                        str(out), "--count", str(n), "--workers", "0", "--maps", "stored"], capture_output=True,
                       text=True, timeout=60, env=env)  # stored maps: a recipe store takes ~60 bytes a blend
    assert r.returncode == 2, r.stderr[-2000:]
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    m = re.search(r"need about ([\d.]+) GiB of disk .* than the ([\d.]+) GiB free", lines[0])
    assert m, lines[0]
    need, free = float(m.group(1)), float(m.group(2))
    assert need > free and abs(need / free - 1.5) < 0.1, lines[0]  # the estimate and the real free space
    assert not list(tmp_path.iterdir()), list(tmp_path.rglob("*"))  # no store, no .partial, no lock, no folder


def test_paper_scale_render_estimate_names_the_expected_size(tmp_path):
    """At the paper's scale (21,836 SVBRDFs x 10 views at 288²) the estimate is the size of the store to expect,
    tens of GB (render.json measures 1.93x compression of a renders store's raw bytes), not the 1/64 floor."""
    from storage.renders_store import array_specs as render_specs

    per = bounds.sample_bytes(render_specs(10, 288, 288))
    n = 1836 + 20000
    free = bounds.free_disk(tmp_path)
    expected = n * per / bounds.EXPECTED_COMPRESSION
    assert 30e9 < expected < 60e9, expected
    if expected > free:
        with pytest.raises(ConfigError, match="GiB free"):
            bounds.check_store_size(tmp_path / "r.zarr", n, 1, render_specs(10, 288, 288))
    else:  # this disk holds it: nothing refused
        bounds.check_store_size(tmp_path / "r.zarr", n, 1, render_specs(10, 288, 288))
    with pytest.raises(ConfigError, match=r"need about [\d.]+ GiB of disk .* GiB free"):
        bounds.check_store_size(tmp_path / "r.zarr", _too_many(tmp_path, per), 1, render_specs(10, 288, 288))
    assert not list(tmp_path.iterdir())


def test_a_resume_needs_only_the_rest(tmp_path):
    """Bytes already in the .partial store count as written: a resume on a nearly full disk is not refused."""
    part = tmp_path / "v.zarr.partial"
    part.mkdir()
    (part / "shard").write_bytes(b"x" * 100_000)
    assert bounds._partial_bytes(tmp_path / "v.zarr") == 100_000
    assert bounds._partial_bytes(tmp_path / "other.zarr") == 0
