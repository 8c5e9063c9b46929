"""`svgen render --scheduler-address` on a real distributed cluster (`dask scheduler` + 2 `dask worker`
processes on 127.0.0.1) writes the same bytes as a run in one process."""
from __future__ import annotations

import os
import subprocess

import pytest
from dask_procs import dask_command, start_scheduler, wait_for_workers
from test_render_resume import _svgen, reference, variants  # noqa: F401  (shared module fixtures)

from conftest import stop_processes, tree_digest


@pytest.mark.slow
def test_distributed_cluster_gives_the_same_bytes(variants, reference, tmp_path):
    """A real scheduler and two workers as separate processes, reached through --scheduler-address."""
    dask = dask_command()
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": os.getcwd()}
    scheduler, addr = start_scheduler(env)
    procs = [scheduler]
    try:
        for _ in range(2):
            procs.append(subprocess.Popen([dask, "worker", addr, "--nthreads", "1", "--nworkers", "1",
                                           "--dashboard-address", ":0", "--no-nanny"],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env))
        wait_for_workers(addr, 2)
        out = tmp_path / "dist.zarr"
        r = subprocess.run(_svgen(variants, out, "--scheduler-address", addr), capture_output=True, text=True,
                           env=env, timeout=240)
        assert r.returncode == 0, r.stderr
        assert tree_digest(out) == tree_digest(reference)
    finally:
        stop_processes(procs)
