"""A dask cluster of separate processes writing ``s3://`` stores (issue #12): a `dask scheduler` and `dask worker`
processes on 127.0.0.1, as on several machines (README "On a cluster"), against the loopback S3 server.

- The workers take the endpoint and credentials from their own environment (``AWS_*``), never from the client's
  command line; the chunk objects and their markers are written by the workers and the client only plans and
  commits. Each process signs its requests with its own access key, and the S3 server (moto, in this process)
  reports through its request-recorder hook which key signed each PUT.
- A worker without the endpoint in its environment fails the run with one line, however the client was told it.
- A worker killed with SIGKILL while a chunk task is in flight: the scheduler reruns the task on another worker
  (``distributed.scheduler.allowed-failures``) and the store ends complete and byte-identical to a one-process run.
"""
from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from urllib.parse import urlparse

import pytest
from dask_procs import dask_command, start_scheduler, wait_for_workers
from s3_fixtures import BUCKET, s3, s3_server  # noqa: F401  (fixtures)
from test_store_s3 import assert_same_store

from conftest import stop_processes

N_SVBRDF = 6
SAMPLE = ["--config-preset", "tiny", "--preset", "paint/glossy_red", "--preset", "wood/mahogany_veneer",
          "--per-preset", str(N_SVBRDF // 2), "--chunk", "2"]  # 3 chunk tasks
ARGS = ["--config-preset", "tiny", "--res", "32", "--views", "2", "--chunk", "1"]  # 6 chunk tasks
WORKER_KEYS = ("WORKERKEY0", "WORKERKEY1")
CLIENT_KEY = "CLIENTKEY"

pytestmark = pytest.mark.slow


def _svgen(*args) -> list[str]:
    return [sys.executable, "-c", "from pipeline.cli import main; main()", *map(str, args)]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _base_env() -> dict[str, str]:
    """This environment without any S3 settings: each process below gets only the ones it is meant to have."""
    drop = ("AWS_ACCESS_KEY_ID", "AWS_SECRET_ACCESS_KEY", "AWS_ENDPOINT_URL", "AWS_ENDPOINT_URL_S3",
            "SVGEN_STORAGE_OPTIONS", "DASK_SCHEDULER_ADDRESS")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    # no credentials from files either (there are none here; a developer's ~/.aws must not make the test pass)
    env.update({"SVGEN_NO_PROGRESS": "1", "PYTHONPATH": os.getcwd(), "AWS_SHARED_CREDENTIALS_FILE": os.devnull,
                "AWS_CONFIG_FILE": os.devnull, "AWS_DEFAULT_REGION": "us-east-1"})
    return env


def worker_env(endpoint: str, key: str) -> dict[str, str]:
    """What a worker machine needs (README "On a cluster"): the credentials and endpoint, the daemon setting."""
    return {**_base_env(), "AWS_ACCESS_KEY_ID": key, "AWS_SECRET_ACCESS_KEY": "worker-secret",
            "AWS_ENDPOINT_URL": endpoint, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}


class Cluster:
    """`dask scheduler` and `dask worker` processes on 127.0.0.1 (README "On a cluster", step 4)."""

    def __init__(self, scheduler_env: dict | None = None):
        self.dask = dask_command()
        self.workers: list[subprocess.Popen] = []
        scheduler, self.address = start_scheduler({**_base_env(), **(scheduler_env or {})})
        self.procs = [scheduler]

    def add_worker(self, env: dict[str, str], nanny: bool = True) -> subprocess.Popen:
        """A worker as README says (under a nanny, which restarts it if it dies), or without one (``nanny=False``:
        the worker is this process, so a SIGKILL to it is the death of a worker, not restarted in place)."""
        p = subprocess.Popen([self.dask, "worker", self.address, "--nthreads", "1", "--dashboard-address", ":0",
                              "--host", "127.0.0.1", *(() if nanny else ("--no-nanny",))],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        self.procs.append(p)
        self.workers.append(p)
        return p

    def wait(self, n: int) -> None:
        wait_for_workers(self.address, n)

    def stop(self) -> None:
        stop_processes(self.procs)


@pytest.fixture
def cluster():
    made: list[Cluster] = []

    def start(scheduler_env: dict | None = None) -> Cluster:
        made.append(Cluster(scheduler_env))
        return made[-1]

    yield start
    for c in made:
        c.stop()


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """(local variants store, local renders store of it), each written by one process (--workers 0)."""
    d = tmp_path_factory.mktemp("s3cluster")
    variants, ref = d / "variants.zarr", d / "ref.zarr"
    for cmd in (("sample", variants, *SAMPLE), ("render", variants, ref, *ARGS)):
        r = subprocess.run(_svgen(*cmd, "--workers", "0"), capture_output=True, text=True, env=_base_env(),
                           timeout=300)
        assert r.returncode == 0, r.stderr
    return variants, ref


def client_cmd(s3, address: str, *args) -> list[str]:
    """The client's command: endpoint and its own credentials on its command line only (not in its environment,
    so nothing of them can reach a worker but through svgen itself)."""
    return _svgen(*args, "--scheduler-address", address, "--storage-option", f"endpoint_url={s3.endpoint}",
                  "--storage-option", f"key={CLIENT_KEY}", "--storage-option", "secret=client-secret")


@pytest.fixture
def recording(s3, monkeypatch):
    """The S3 server's own view of who wrote what: moto's request-recorder hook (called by the server, which runs
    in this process, for every request it receives) replaced by one that keeps (method, key in the bucket, access
    key that signed the request). Returns a function giving that list so far."""
    from moto.moto_api import recorder

    seen: list[tuple[str, str, str]] = []

    def record(request, body=None) -> None:  # moto's signature; runs in the server's request threads
        auth = request.headers.get("Authorization", "")
        m = re.search(r"Credential=([^/]+)/", auth)
        path = urlparse(request.url).path.lstrip("/")
        key = path[len(BUCKET) + 1:] if path.startswith(BUCKET + "/") else ""
        seen.append((request.method, key, m.group(1) if m else ""))  # list.append: atomic across threads

    monkeypatch.setattr(recorder, "_record_request", record)
    return lambda: list(seen)


def test_separate_process_cluster_writes_s3_with_its_own_credentials(s3, inputs, cluster, recording):
    """`dask scheduler` + 2 `dask worker` processes whose environment alone holds the endpoint and their
    credentials; `svgen sample` and `svgen render` to s3:// with --scheduler-address give the bytes of
    one-process local runs, every chunk object and marker was put by a worker (signed with a worker's key), and
    the client put only metadata, the manifest and the lock."""
    variants, ref = inputs
    c = cluster()
    for key in WORKER_KEYS:
        c.add_worker(worker_env(s3.endpoint, key))
    c.wait(2)
    for cmd in (("sample", s3.url("v.zarr"), *SAMPLE), ("render", s3.url("v.zarr"), s3.url("r.zarr"), *ARGS)):
        r = subprocess.run(client_cmd(s3, c.address, *cmd), capture_output=True, text=True, env=_base_env(),
                           timeout=300)
        assert r.returncode == 0, r.stderr
    assert_same_store(s3, s3.url("v.zarr"), variants)
    assert_same_store(s3, s3.url("r.zarr"), ref)

    for name, local in (("v.zarr", variants), ("r.zarr", ref)):
        puts = [(key, who) for method, key, who in recording() if method == "PUT" and key.startswith(name)]
        # the name arrays (preset_name, category_name: storage/labels.py) are derived from the index arrays when the
        # store is committed, so the client writes them with the metadata; every sample chunk is a worker's
        names = [(k, w) for k, w in puts if len(k.split("/")) > 1 and k.split("/")[1].endswith("_name")]
        assert {w for _, w in names} <= {CLIENT_KEY}, f"{name}: a worker wrote the name arrays"
        puts = [(k, w) for k, w in puts if (k, w) not in names]
        chunk_puts = [(k, w) for k, w in puts if "/c/" in k or "/.done/" in k]
        writers = {w for _, w in chunk_puts}
        assert chunk_puts and writers == set(WORKER_KEYS), \
            f"{name}: chunk objects and markers were put by {writers}, not by both workers alone"
        assert {k for k, _ in chunk_puts if "/c/" in k} == {
            f"{name}/{p.relative_to(local)}" for p in local.rglob("*") if p.is_file() and "/c/" in
            str(p.relative_to(local)) and not p.relative_to(local).parts[0].endswith("_name")}
        client = sorted({k for k, w in puts if w == CLIENT_KEY})
        assert f"{name}/zarr.json" in client and f"{name}/svgen_manifest.json" in client, client  # it commits
        assert {w for k, w in puts if k.endswith(("zarr.json", "svgen_manifest.json", ".lock"))} == {CLIENT_KEY}, \
            f"{name}: a worker wrote metadata, the manifest or the lock"
        assert not [k for k in client if "/c/" in k or "/.done/" in k], f"{name}: the client wrote chunks itself"


def _processing(address: str) -> dict[str, list]:
    """worker address -> keys of the tasks the scheduler has sent it and not yet seen finish."""
    from distributed import Client

    with Client(address, timeout="30s") as c:
        return {w: list(ks) for w, ks in c.processing().items()}


def _pids(address: str) -> dict[str, int]:
    from distributed import Client

    with Client(address, timeout="30s") as c:
        return c.run(os.getpid)


def test_worker_killed_mid_task_the_store_ends_identical(s3, inputs, cluster):
    """Three worker processes; once a chunk is done and a worker has another chunk task in flight, it is stopped (SIGSTOP, so that the task
    cannot finish in between), the scheduler is asked again that the task is still its, and it is killed with
    SIGKILL. The scheduler reruns the task on a surviving worker and the store ends complete and identical to a
    one-process run. (A dead worker's task is rerun by the scheduler's ``allowed-failures`` (3), not by the task
    ``retries`` of pipeline.exec.parallel.RETRIES, which rerun a task that raised: with ``allowed-failures`` 0 this
    test fails with KilledWorker; with RETRIES 0 it passes.)"""
    variants, ref = inputs
    s3.fs().put(str(variants), f"{s3.bucket}/in/variants.zarr", recursive=True)
    c = cluster()
    for i in range(3):
        c.add_worker(worker_env(s3.endpoint, f"WORKERKEY{i}"), nanny=False)
    c.wait(3)
    pids = _pids(c.address)
    out = s3.url("k.zarr")
    proc = subprocess.Popen(client_cmd(s3, c.address, "render", s3.url("in/variants.zarr"), out, *ARGS),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_base_env())
    victim, fs, done = None, s3.fs(), f"{s3.bucket}/k.zarr/.done"
    deadline = time.time() + 180
    while victim is None and time.time() < deadline and proc.poll() is None:
        fs.invalidate_cache()
        if not fs.exists(done) or not fs.find(done):
            time.sleep(0.05)
            continue  # mid-render: a part of the store written first
        for addr, keys in _processing(c.address).items():
            if keys:
                os.kill(pids[addr], signal.SIGSTOP)
                time.sleep(1.0)  # any result it sent before the stop reaches the scheduler meanwhile
                if set(keys) & set(_processing(c.address).get(addr, [])):
                    victim = addr
                    os.kill(pids[addr], signal.SIGKILL)
                else:
                    os.kill(pids[addr], signal.SIGCONT)
                break
        time.sleep(0.05)
    try:
        _, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert victim is not None, "no worker could be killed with a task in flight: the test proves nothing"
    assert proc.returncode == 0, err
    assert_same_store(s3, out, ref)
    from distributed import Client

    with Client(c.address, timeout="30s") as cl:
        assert victim not in cl.scheduler_info()["workers"], "the killed worker is still listed"


def test_a_worker_without_the_endpoint_fails_with_one_line(s3, cluster):
    """The client's --storage-option does not travel to the cluster's workers: a worker whose own environment
    names a closed endpoint fails the run with one line naming that endpoint, and no store is left."""
    c = cluster()
    dead = f"http://127.0.0.1:{_free_port()}"
    c.add_worker(worker_env(dead, WORKER_KEYS[0]))
    c.wait(1)
    r = subprocess.run(client_cmd(s3, c.address, "sample", s3.url("v.zarr"), *SAMPLE), capture_output=True,
                       text=True, env=_base_env(), timeout=300)
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.strip()]
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    assert "unreachable" in lines[0] and dead in lines[0], lines[0]
    assert not s3.fs().find(f"{s3.bucket}/v.zarr"), "a failed run left a store"
