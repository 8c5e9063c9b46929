"""`svgen render` killed with SIGKILL: no complete-looking store, a rerun renders only what is missing and ends
byte-identical to an uninterrupted run; a second run on the same output is refused."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from conftest import chunk_stats, tree_digest
from pipeline.config import SampleConfig
from storage.renders_store import RendersReader
from pipeline.sample import run_sample
from storage.store import DONE_DIR, partial_path
from svcore.config import build
from svcore.errors import StoreError

N_SVBRDF = 6
ARGS = ["--config-preset", "tiny", "--res", "96", "--views", "3", "--chunk", "1"]


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    out = tmp_path_factory.mktemp("resume_in") / "variants.zarr"
    run_sample(out, build(SampleConfig, "tiny", presets=("paint/glossy_red", "wood/mahogany_veneer"),
                          per_preset=N_SVBRDF // 2), workers=0)
    return out


def _svgen(inp, out, *extra):
    return [sys.executable, "-c", "from pipeline.cli import main; main()", "render", str(inp), str(out), *ARGS,
            *extra]


@pytest.fixture(scope="module")
def reference(variants, tmp_path_factory):
    out = tmp_path_factory.mktemp("resume_ref") / "ref.zarr"
    subprocess.run(_svgen(variants, out, "--workers", "0"), check=True, capture_output=True)
    return out


def _wait_for_chunks(out, n, timeout=120):
    done = partial_path(out) / DONE_DIR
    deadline = time.time() + timeout
    while time.time() < deadline and not (done.exists() and len(list(done.iterdir())) >= n):
        time.sleep(0.02)
    return done


def test_sigkill_then_rerun_matches_uninterrupted_run(variants, reference, tmp_path):
    out = tmp_path / "killed.zarr"
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1"}
    proc = subprocess.Popen(_svgen(variants, out, "--workers", "0"), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=env)
    done = _wait_for_chunks(out, 2)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    n_done = len(list(done.iterdir()))
    if n_done >= N_SVBRDF:
        pytest.skip("the run finished before it could be killed")
    assert not out.exists()
    with pytest.raises(StoreError, match="incomplete"):
        RendersReader(out)
    finished = sorted(int(m.name) for m in done.iterdir())
    kept = chunk_stats(partial_path(out), finished, "image", 5)
    r = subprocess.run(_svgen(variants, out, "--workers", "0"), capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert tree_digest(out) == tree_digest(reference)
    assert not partial_path(out).exists()
    assert chunk_stats(out, finished, "image", 5) == kept, "the rerun rewrote chunks finished before the kill"


def test_a_second_run_on_the_same_output_is_refused(variants, tmp_path):
    out = tmp_path / "busy.zarr"
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1"}
    first = subprocess.Popen(_svgen(variants, out, "--workers", "0"), stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL, env=env)
    try:
        _wait_for_chunks(out, 1)
        # Freeze the first run mid-store: it holds the store, alive, for as long as the second takes to start
        # (without this the first could finish first on a fast machine and the refusal would go untested).
        os.kill(first.pid, signal.SIGSTOP)
        assert first.poll() is None and not out.exists(), "the first run finished before it could be frozen"
        second = subprocess.run(_svgen(variants, out, "--workers", "0"), capture_output=True, text=True, env=env)
        assert second.returncode != 0 and "another run is writing" in second.stderr, second.stderr
    finally:
        first.kill()
        first.wait()
