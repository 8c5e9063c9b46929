"""Run a stage's chunk tasks with dask.distributed: local worker processes by default, or any scheduler.

Every task is a pure function of its chunk id (and the stage's config), writes
its own chunk and returns how many units it produced; so the store's bytes do
not depend on the number of workers or on where they run.

Retries: a task that raises is run again, up to :data:`RETRIES` times, which is safe because a task is idempotent:
it rewrites its whole chunk (zarr writes each chunk file to a temporary name and renames it) and only then writes
the chunk's done-record (hashes of the chunk files, renamed into place too), so a task stopped anywhere leaves
either no record or the record of a complete chunk, and its rerun writes the same bytes again. Failures that will
not go away by themselves (svgen's own SvgenError, a full disk, a read-only or forbidden path) are not retried:
the task hands them back as a value and the client raises them at once. A worker *process* that dies mid-task is a
separate mechanism: the scheduler reruns its tasks elsewhere (``distributed.scheduler.allowed-failures``, 3).

Threads: drjit and numpy get a thread budget per worker process, computed *on that worker* from its own CPUs
(``os.sched_getaffinity``) divided by the worker processes on its host, not from the calling machine's core count
(wrong on a remote cluster whose machines differ from the client's).
"""
from __future__ import annotations

import errno
import functools
import itertools
import logging
import os
import warnings
from contextlib import contextmanager
from typing import Callable, Iterable

from svcore.errors import ConfigError, SvgenError
from svcore.log import get_logger
from svcore.progress import progress

log = get_logger(__name__)

SCHEDULER_ENV = "DASK_SCHEDULER_ADDRESS"
#: times dask reruns a chunk task that raised: two, so that a transient failure (a reset connection or a stale
#: handle on a network file system, a killed thread) may strike twice in one chunk before the stage fails, while a
#: real bug costs at most three runs of one chunk before the user sees it.
RETRIES = 2
#: OS errors that a rerun cannot fix: reported at once, not retried.
PERMANENT_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM})


def resolve_scheduler(address: str | None) -> str | None:
    """The scheduler address to use: the option, else ``DASK_SCHEDULER_ADDRESS``, else None (local)."""
    return address or os.environ.get(SCHEDULER_ENV) or None


@contextmanager
def dask_client(workers: int, scheduler_address: str | None = None, connect_timeout: float = 10.0):
    """A dask.distributed Client: connected to ``scheduler_address`` or on a fresh local process cluster.

    Args:
        workers: local worker processes (ignored with a scheduler address).
        scheduler_address: e.g. "tcp://127.0.0.1:8786".
        connect_timeout: seconds to wait for a remote scheduler.

    Raises:
        ConfigError: bad worker count or unreachable scheduler.

    The client is never dask's default (``set_as_default=False``): svgen submits to it by name, and a default
    client sets ``dask.config`` scheduler="dask.distributed" in this process, which distributed leaves behind when
    the connection fails ("notaurl") or clients close out of order; every later ``.compute()`` here (xarray reading
    a store) then failed with "no Client active" (CI of stop 31, tests/test_parallel.py).
    """
    import dask
    from distributed import Client, LocalCluster

    # another cluster on this machine holds the default dashboard port: distributed warns on stderr and moves on
    warnings.filterwarnings("ignore", message="Port .* is already in use", category=UserWarning)
    if not log.isEnabledFor(logging.DEBUG):  # distributed sets its loggers to INFO when imported
        for name in ("distributed", "distributed.nanny", "distributed.scheduler", "distributed.core"):
            logging.getLogger(name).setLevel(logging.WARNING)
        # closing the cluster after a failed task on a loaded machine: "Worker process still alive after 4.0
        # seconds, killing" would be a second line under svgen's one-line error (seen in test_faults under load)
        logging.getLogger("distributed.nanny").setLevel(logging.ERROR)

    if scheduler_address:
        try:
            client = Client(scheduler_address, timeout=f"{connect_timeout}s", set_as_default=False)
        except (OSError, TimeoutError) as e:
            raise ConfigError(f"cannot reach the dask scheduler at {scheduler_address}: {e}") from None
        except ValueError as e:  # distributed's address parser: "notaurl" is not host:port
            raise ConfigError(f"scheduler address {scheduler_address!r} is not a dask address "
                              f"(e.g. tcp://127.0.0.1:8786): {e}") from None
        try:
            yield client
        finally:
            client.close()
        return
    if workers < 1:
        raise ConfigError(f"--workers must be >= 1 for a local cluster, got {workers}")
    # daemon=False: worker processes may start their own pools (drjit threads, torch loaders).
    # MALLOC_TRIM_THRESHOLD_ unset (None): dask's nanny sets it to 64 KiB in every worker, and setting it at all
    # turns off glibc's dynamic mmap threshold, so every map-sized array (> 128 KiB) is a fresh mmap, page-faulted
    # in and unmapped again: the data stages spent more CPU in the kernel than in their work (svgen sample with 2
    # workers: 47.9 s wall, 45 s system CPU, 18.8 s without; experiments/worker_env). A value the user exported
    # still holds (the workers inherit this process's environment).
    with dask.config.set({"distributed.worker.daemon": False,
                          "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None, **QUIET_LOCAL_CLUSTER}):
        # a failing task's exception reaches the client (fut.result() re-raises it, and the CLI prints one line);
        # the workers' own "Compute Failed" report of it (5 lines at ERROR) is shown only with --verbose
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR if log.isEnabledFor(logging.DEBUG) else logging.CRITICAL)
        try:
            with Client(cluster, set_as_default=False) as client:
                yield client
        finally:
            cluster.close()


#: distributed's periodic work that serves a dashboard, or memory management of task results, run less often in svgen's
#: local clusters, which have no dashboard and whose tasks write their chunks and return a count (their memory is
#: bounded before the stage starts: storage.bounds). At dask's defaults an idle local worker used about 3 % of a
#: core and the cluster's parent process about 4 % (experiments/worker_quiet). A remote scheduler's workers keep
#: their own settings.
QUIET_LOCAL_CLUSTER = {
    "distributed.worker.profile.enabled": False,  # the statistical profiler: every thread's stack sampled each 10 ms
    "distributed.admin.tick.interval": "500ms",  # the event loop's responsiveness check (20 ms)
    "distributed.admin.system-monitor.interval": "5s",  # CPU, memory and network samples for the dashboard (500 ms)
    "distributed.worker.memory.monitor-interval": "1s",  # worker and nanny memory checks (100 ms)
}


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask: a container's or ``taskset``'s limit), else the count."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        return os.cpu_count() or 1


def workers_per_host(client) -> dict[str, int]:
    """host -> worker processes the scheduler knows on it."""
    hosts: dict[str, int] = {}
    for w in client.scheduler_info(n_workers=-1).get("workers", {}).values():
        hosts[w["host"]] = hosts.get(w["host"], 0) + 1
    return hosts


def worker_threads(hosts: dict[str, int]) -> int:
    """In a worker: its thread budget for drjit/numpy, its host's usable CPUs // worker processes on that host.

    drjit has its own thread pool; without this, N worker processes on one machine would each start ``cores``
    threads and oversubscribe it. A worker that joined after the task was sent (a host not in ``hosts``) counts
    as alone on its host.
    """
    from distributed import get_worker
    from distributed.comm import get_address_host

    return max(1, usable_cpus() // max(1, hosts.get(get_address_host(get_worker().address), 1)))


def threads_per_worker(client) -> int:
    """The budget :func:`worker_threads` gives on a worker (benchmarks record it). A task, not ``client.run``:
    ``get_worker`` finds no worker in a function ``client.run`` calls."""
    return int(client.submit(worker_threads, workers_per_host(client), pure=False).result())


class _Permanent:
    """An exception a task hands back instead of raising it, so that dask does not retry it."""

    def __init__(self, error: BaseException):
        self.error = error


def _on_worker(fn: Callable[[int, int], int], hosts: dict[str, int], c: int):
    """Run chunk task ``fn(c, threads)`` in a worker with that worker's own thread budget."""
    try:
        return fn(c, worker_threads(hosts))
    except SvgenError as e:
        return _Permanent(e)
    except OSError as e:
        if e.errno in PERMANENT_ERRNOS:
            return _Permanent(e)
        raise


#: tasks kept submitted per worker: enough that no worker waits for the client, few enough that the scheduler
#: holds a handful of tasks, not a whole stage's.
WINDOW_PER_WORKER = 4


def run_chunks(fn: Callable[[int, int], int], chunks: Iterable[int], *, workers: int = 2, scheduler_address: str | None = None,
               desc: str = "chunks", unit: str = "it", total_units: int | None = None, done_units: int = 0,
               task_bytes: int = 0) -> int:
    """Run ``fn(chunk_id, threads) -> units`` for every chunk on dask and show a units/s progress bar.

    Args:
        fn: picklable, idempotent function; runs in the workers with the thread budget of its worker
            (:func:`worker_threads`); returns the number of units (samples, views) written. A call that raises is
            retried (:data:`RETRIES`) unless the error is permanent (SvgenError, :data:`PERMANENT_ERRNOS`).
        chunks: chunk ids still to do.
        workers: local processes when no scheduler is given; 0 runs the chunks in this process.
        scheduler_address: a running dask.distributed scheduler (or ``DASK_SCHEDULER_ADDRESS``).
        desc, unit: progress bar label and unit.
        total_units: units of the whole stage; done_units: already written (resume).
        task_bytes: estimated peak memory of one task (StoreWriter.task_bytes); bounds the local workers.

    Returns:
        Units written by this call.
    """
    chunks = list(chunks)
    if not chunks:
        return 0
    address = resolve_scheduler(scheduler_address)
    if not address:
        from storage.bounds import check_workers

        check_workers(max(1, workers), task_bytes)
    written = 0
    if workers == 0 and not address:
        # in this process, one chunk after another (debugging, profiling, tiny runs)
        with progress(total=total_units or len(chunks), desc=desc, unit=unit, initial=done_units) as bar:
            for c in chunks:
                n = fn(c, os.cpu_count() or 1)
                written += n
                bar.update(n)
        return written
    # the bar first (a cluster takes seconds to start), and the tasks in a window of a few per worker: submitting
    # every chunk up front kept a large stage silent for minutes while the scheduler took its graph
    bar = progress(total=total_units or len(chunks), desc=desc, unit=unit, initial=done_units)
    try:
        with dask_client(workers, address) as client:
            # distributed only imported for a stage that runs dask tasks (its import is ~0.5 s of every start)
            from distributed import KilledWorker, as_completed
            task = functools.partial(_on_worker, fn, workers_per_host(client))
            window = max(8, WINDOW_PER_WORKER * len(client.scheduler_info().get("workers", {})))
            todo = iter(chunks)
            pending: set = set()
            running = as_completed(loop=client.loop)

            def submit(c: int) -> None:
                fut = client.submit(task, c, pure=False, retries=RETRIES)
                pending.add(fut)
                running.add(fut)

            for c in itertools.islice(todo, window):
                submit(c)
            try:
                for fut in running:
                    pending.discard(fut)
                    try:
                        n = fut.result()  # re-raises the worker's exception after the retries
                    except KilledWorker as e:  # dask's own retries after worker deaths are used up
                        raise SvgenError(
                            "the workers running a chunk task kept dying (dask KilledWorker after the scheduler's "
                            "allowed-failures: out of memory, or killed?); the store is resumable: rerun the command") from e
                    if isinstance(n, _Permanent):
                        raise n.error  # SvgenError stays an SvgenError, ENOSPC an OSError
                    written += n
                    bar.update(n)
                    nxt = next(todo, None)
                    if nxt is not None:
                        submit(nxt)
            except BaseException:
                client.cancel(list(pending))
                raise
    finally:
        bar.close()
    return written
