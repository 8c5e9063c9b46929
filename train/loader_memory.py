"""The training loader's memory: one budget for the whole run, shared by its processes.

A renders store reader keeps caches (decoded chunks, base maps as planes: :class:`storage.renders_store.RendersReader`)
and every loader worker holds its own copy of the reader, so a per-reader budget multiplies with ``data.workers``
(and with the data-parallel processes on the machine). Here ``data.loader_memory_mib`` is the run's total on this
machine: it is divided among the ``local_size x (workers + 1)`` processes that read (each rank's main process reads
too: the held-out probe), and :func:`share` hands each its part before the workers start. A budget that cannot
give every process the reader's minimum, or that the machine does not have, is refused in one line, before the run
directory exists (as ``train.runinfo.check_run`` refuses activations that do not fit).
"""
from __future__ import annotations

from svcore.errors import ConfigError

#: the automatic budget: at most this many bytes ...
AUTO_CAP = 4 << 30
#: ... and at most this fraction of the memory available when the run starts.
AUTO_FRACTION = 0.25
MIB = 1 << 20


def processes(workers: int, local_size: int = 1) -> int:
    """Processes on this machine that hold a reader: each rank's main process and its loader workers."""
    return max(1, local_size) * (int(workers) + 1)


def total_budget(data_cfg, available: int | None = None) -> int:
    """Bytes the loader may keep cached on this machine: ``data.loader_memory_mib``, or (0, automatic) the smaller
    of :data:`AUTO_CAP` and :data:`AUTO_FRACTION` of the available memory."""
    if data_cfg.loader_memory_mib:
        return int(data_cfg.loader_memory_mib) * MIB
    if available is None:
        from storage.bounds import available_memory

        available = available_memory()
    return int(min(AUTO_CAP, AUTO_FRACTION * available))


def per_process(data_cfg, src, local_size: int = 1, available: int | None = None) -> int | None:
    """Each reading process's share of the budget, checked (None: the source keeps no caches, nothing to share).

    Args:
        data_cfg: the run's ``data`` config (``workers``, ``loader_memory_mib``).
        src: the data source (a renders store reader has ``min_cache_bytes``; other sources are not checked).
        local_size: data-parallel processes on this machine.
        available: bytes of memory available (default: measured now).

    Raises:
        ConfigError: the budget, or the processes' minimum caches, exceed the available memory, or the budget
            leaves a process less than the reader's minimum.
    """
    least = getattr(src, "min_cache_bytes", None)
    if least is None:
        return None
    least = int(least())
    if available is None:
        from storage.bounds import available_memory

        available = available_memory()
    n = processes(data_cfg.workers, local_size)
    budget = total_budget(data_cfg, available)
    who = f"data.workers={data_cfg.workers}" + (f" on each of {local_size} processes" if local_size > 1 else "")
    fit_in = max(0, min(budget, available) // least // max(1, local_size) - 1)
    if n * least > available:
        raise ConfigError(f"{who}: {n} loader processes need at least {n * least / MIB:.0f} MiB of cache "
                          f"({least / MIB:.1f} MiB each for this store), more than the {available / MIB:.0f} MiB of "
                          f"memory available; use at most {fit_in} workers")
    if data_cfg.loader_memory_mib and budget > available:
        raise ConfigError(f"data.loader_memory_mib={data_cfg.loader_memory_mib} is more than the "
                          f"{available / MIB:.0f} MiB of memory available; use at most {available // MIB} "
                          f"(0: automatic)")
    if n * least > budget:
        raise ConfigError(f"{who}: the loader budget of {budget / MIB:.0f} MiB leaves each of its {n} processes less "
                          f"than the {least / MIB:.1f} MiB one needs for this store; raise data.loader_memory_mib "
                          f"or use at most {fit_in} workers")
    return budget // n


def share(src, nbytes: int | None) -> None:
    """Give ``src`` (and so every worker forked with it) a cache budget of ``nbytes`` (None: leave it)."""
    if nbytes is not None and hasattr(src, "set_cache_bytes"):
        src.set_cache_bytes(nbytes)
