"""The two benchmarks that compare checkouts on one machine measure what they say: bench_cli_start counts the child
process's CPU and refuses a failed command, and bench_materials' A/B runs each checkout's own code."""
from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import bench_cli_start as bcs  # noqa: E402
import bench_materials as bm  # noqa: E402


def test_cli_start_counts_the_child_process_cpu(tmp_path):
    """A child that burns ~0.3 s of CPU reads as such (this process's own CPU would read ~0)."""
    burn = "import time\nt = time.process_time()\nwhile time.process_time() - t < 0.3: pass\n"
    wall, cpu = bcs.run_once(tmp_path, [sys.executable, "-c", burn])
    assert 0.25 <= cpu <= wall + 0.2, (wall, cpu)


def test_cli_start_refuses_a_failed_command(tmp_path):
    with pytest.raises(SystemExit, match="failed"):
        bcs.run_once(tmp_path, [sys.executable, "-c", "import sys; sys.exit(3)"])


def _fake_checkout(root: Path, burn_s: float) -> Path:
    """A checkout whose ``materials.presets()`` are 4 presets that each burn ``burn_s`` of CPU per generation."""
    pkg = root / "materials"
    pkg.mkdir(parents=True)
    pkg.joinpath("__init__.py").write_text(textwrap.dedent(f"""
        import time
        from types import SimpleNamespace

        class Preset:
            exposed = [SimpleNamespace(name="a", low=0.0, high=1.0)]

            def generate(self, params, size, seed):
                t = time.process_time()
                while time.process_time() - t < {burn_s}:
                    pass

        def presets():
            return [Preset() for _ in range(4)]
    """))
    return root


def test_materials_ab_runs_each_checkouts_own_code(tmp_path, monkeypatch):
    """The slow checkout reads slow and the fast one fast, under their own labels (a swapped or shared code path
    would read the same for both)."""
    slow = _fake_checkout(tmp_path / "slow", 0.1)
    fast = _fake_checkout(tmp_path / "fast", 0.02)
    monkeypatch.setattr(bm, "ROOT", fast)  # "this" checkout: the fast one
    ab = bm.same_machine_ab(slow, rounds=1)
    rate = ab["median"]
    assert rate["against"] == pytest.approx(10.0, rel=0.3) and rate["this"] == pytest.approx(50.0, rel=0.3), ab
