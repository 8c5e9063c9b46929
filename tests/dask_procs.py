"""A `dask scheduler` process on 127.0.0.1 for the tests that run clusters of separate processes.

The scheduler binds a port of its own choosing (``--port 0``) and writes its address to a scheduler file; the test
reads the address from there. A port picked by the test and released before the scheduler bound it could be taken
in between by any other process of a parallel run (a worker's dashboard, say): the client then reached that
process, never got the scheduler's answer, and failed after 60 s (CI of stop 54).
"""
from __future__ import annotations

import json
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import pytest

#: seconds a starting scheduler or worker gets on a loaded 2-core machine (imports alone take several)
START_TIMEOUT = 120


def dask_command() -> str:
    """The `dask` command (dask[distributed], a requirement: absent is a failure, not a skip)."""
    dask = shutil.which("dask")
    if dask is None:
        pytest.fail("the `dask` command (distributed) is not installed")
    return dask


def start_scheduler(env: dict[str, str]) -> tuple[subprocess.Popen, str]:
    """Start `dask scheduler` on 127.0.0.1 and wait until it listens.

    Args:
        env: the scheduler process's environment.

    Returns:
        (the process, its ``tcp://`` address).
    """
    folder = Path(tempfile.mkdtemp(prefix="svgen-scheduler-"))
    file = folder / "scheduler.json"
    proc = subprocess.Popen([dask_command(), "scheduler", "--host", "127.0.0.1", "--port", "0",
                             "--dashboard-address", ":0", "--scheduler-file", str(file)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    deadline = time.monotonic() + START_TIMEOUT
    try:
        while True:
            try:  # written by the scheduler once it listens; read until it is whole JSON
                address = json.loads(file.read_text())["address"]
                break
            except (FileNotFoundError, ValueError, KeyError):
                pass
            if proc.poll() is not None:
                pytest.fail(f"`dask scheduler` exited with code {proc.returncode} before it listened")
            if time.monotonic() > deadline:
                proc.kill()
                pytest.fail(f"`dask scheduler` did not listen within {START_TIMEOUT} s")
            time.sleep(0.1)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return proc, address


def wait_for_workers(address: str, n: int) -> None:
    """Block until the scheduler at ``address`` has ``n`` workers."""
    from distributed import Client

    with Client(address, timeout=f"{START_TIMEOUT}s") as c:
        c.wait_for_workers(n, timeout=START_TIMEOUT)
