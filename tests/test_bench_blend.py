"""benchmarks/bench_blend.py: the steady rate takes the startup out (the small run's wall and CPU), medians over
rounds, and a small run not smaller than the timed one is refused."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import bench_blend as bb  # noqa: E402


def _round(full_wall, small_wall, full_cpu=0.0, small_cpu=0.0):
    return {"full": {"wall_s": full_wall, "cpu_s": full_cpu, "peak_rss_bytes": 1},
            "small": {"wall_s": small_wall, "cpu_s": small_cpu, "peak_rss_bytes": 1}}


def test_steady_rate_is_the_work_without_the_startup():
    # 5 s of startup, then 100 blends/s: 1,000 blends in 15 s, 100 in 6 s; CPU 2 s + 20 ms per blend
    rounds = [_round(15.0, 6.0, 22.0, 4.0), _round(17.0, 6.5, 22.0, 4.0), _round(14.0, 6.0, 22.0, 4.0)]
    s = bb.summary(rounds, 1000, 100)
    assert s["full_wall_s"] == 15.0 and s["small_wall_s"] == 6.0  # medians
    assert s["blends_per_s"] == pytest.approx(1000 / 15.0, abs=0.01)
    assert s["steady_blends_per_s"] == pytest.approx(100.0)
    assert s["cpu_ms_per_blend_steady"] == pytest.approx(20.0)


def test_a_small_run_as_large_as_the_timed_one_is_refused():
    with pytest.raises(SystemExit, match="--small"):
        bb.main(["--count", "64", "--small", "64"])
