"""Run a stage's chunk tasks with dask.distributed: local worker processes by default, or any scheduler.

Every task is a pure function of its chunk id (and the stage's config), writes
its own chunk and returns how many units it produced; so the store's bytes do
not depend on the number of workers or on where they run.
"""
from __future__ import annotations

import logging
import os
from contextlib import contextmanager
from typing import Callable, Iterable

from svcore.errors import ConfigError
from svcore.log import get_logger
from svcore.progress import progress

log = get_logger(__name__)

SCHEDULER_ENV = "DASK_SCHEDULER_ADDRESS"


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
    """
    import dask
    from distributed import Client, LocalCluster

    if not log.isEnabledFor(logging.DEBUG):  # distributed sets its loggers to INFO when imported
        for name in ("distributed", "distributed.nanny", "distributed.scheduler", "distributed.core"):
            logging.getLogger(name).setLevel(logging.WARNING)

    if scheduler_address:
        try:
            client = Client(scheduler_address, timeout=f"{connect_timeout}s")
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
    # daemon=False: worker processes may start their own pools (drjit threads, torch loaders)
    with dask.config.set({"distributed.worker.daemon": False}):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR)
        try:
            with Client(cluster) as client:
                yield client
        finally:
            cluster.close()


def threads_per_worker(client) -> int:
    """CPU threads each worker may give drjit/numpy: cores // workers (at least 1).

    drjit has its own thread pool; without this, N worker processes would each start
    ``cores`` threads and oversubscribe the machine.
    """
    n = max(1, len(client.scheduler_info().get("workers", {})))
    return max(1, (os.cpu_count() or 1) // n)


def run_chunks(fn: Callable[[int, int], int], chunks: Iterable[int], *, workers: int = 2, scheduler_address: str | None = None,
               desc: str = "chunks", unit: str = "it", total_units: int | None = None, done_units: int = 0) -> int:
    """Run ``fn(chunk_id, threads) -> units`` for every chunk on dask and show a units/s progress bar.

    Args:
        fn: picklable function; runs in the workers with the thread budget of one worker (cores // workers);
            returns the number of units (samples, views) written.
        chunks: chunk ids still to do.
        workers: local processes when no scheduler is given; 0 runs the chunks in this process.
        scheduler_address: a running dask.distributed scheduler (or ``DASK_SCHEDULER_ADDRESS``).
        desc, unit: progress bar label and unit.
        total_units: units of the whole stage; done_units: already written (resume).

    Returns:
        Units written by this call.
    """
    from distributed import as_completed

    chunks = list(chunks)
    if not chunks:
        return 0
    address = resolve_scheduler(scheduler_address)
    written = 0
    if workers == 0 and not address:
        # in this process, one chunk after another (debugging, profiling, tiny runs)
        with progress(total=total_units or len(chunks), desc=desc, unit=unit, initial=done_units) as bar:
            for c in chunks:
                n = fn(c, os.cpu_count() or 1)
                written += n
                bar.update(n)
        return written
    with dask_client(workers, address) as client:
        threads = threads_per_worker(client)
        futures = client.map(fn, chunks, [threads] * len(chunks), pure=False)
        bar = progress(total=total_units or len(chunks), desc=desc, unit=unit, initial=done_units)
        try:
            for fut in as_completed(futures):
                n = fut.result()  # re-raises the worker's exception (SvgenError stays an SvgenError)
                written += n
                bar.update(n)
        except BaseException:
            client.cancel(futures)
            raise
        finally:
            bar.close()
    return written
