"""Up-front resource checks: refuse, in one line saying the limit and why, what cannot fit.

Without them a huge ``--chunk``, an astronomically large ``--per-preset`` or ``--workers 500`` ran into the
kernel's OOM killer (exit 137, no message, a lock left behind) or ran silently for hours. The estimates are
deliberately generous to the user: they refuse only what certainly cannot fit.

* memory of one chunk task: ``chunk x raw bytes per sample x TASK_FACTOR`` (the task assembles the chunk's
  arrays, stacks them into one buffer and zarr holds the compressed copy; zarr allocates a whole chunk even for
  the short last one) must fit in the available memory;
* local workers: ``workers x (WORKER_BYTES + task bytes)`` must fit in the available memory;
* disk: the store's expected size, its raw size divided by EXPECTED_COMPRESSION, less what a resumed ``.partial``
  store already holds, must fit in the free space of the output's file system. A paper-scale run (~218,000 views,
  tens of GB) on a disk too small is refused before anything is written, with the estimate and the free space,
  instead of failing hours later with the disk full and a partial store left behind.

(Seeds, integers in [0, 2^64), are a field rule of the configs: ``Field(ge=0, lt=2 ** 64)``.)
"""
from __future__ import annotations

import math
import os
from pathlib import Path

from svcore.errors import ConfigError

from .objstore import local_path

#: peak bytes per chunk task relative to the chunk's raw bytes (arrays assembled, stacked, compressed copy).
TASK_FACTOR = 3
#: resident memory of one dask worker process with numpy, zarr, dask and mitsuba loaded (measured: 150 MiB for
#: the imports and a 64^2 scene, plus the worker's own bookkeeping).
WORKER_BYTES = 200 << 20
#: the compression a store is expected to reach: renders stores, the largest by far, measure 1.93x
#: (benchmarks/results/render.json: 169,607 bytes per 256² view of 327,739 raw); real variants and blends stores
#: compress no better (benchmarks/bench_paper_scale.py records each store's bytes). Not the best conceivable ratio
#: (uniform maps compress 64x and more): a bound that loose let a paper-scale render start on a disk holding a
#: tenth of its output.
EXPECTED_COMPRESSION = 2

GiB = float(1 << 30)


def available_memory() -> int:
    """Bytes of memory available to new allocations: the machine's available memory (psutil, a dependency of
    dask.distributed), or less where this process's cgroup (a container's limit) or its address-space limit
    (``ulimit -v``) leaves less."""
    import psutil

    return int(min(psutil.virtual_memory().available, _cgroup_room(), _address_space_room()))


#: a cgroup memory limit at or above this is "no limit" (cgroup v1 writes 2^63 rounded down to a page).
_NO_LIMIT = 1 << 60


def _cgroup_room(root: Path = Path("/sys/fs/cgroup")) -> float:
    """Bytes left under this container's cgroup memory limit (v2 ``memory.max``, v1 ``memory.limit_in_bytes``)
    less its usage, counting reclaimable inactive file cache as free; infinite without a limit."""
    for limit_f, usage_f, stat_f, inactive in (("memory.max", "memory.current", "memory.stat", "inactive_file"),
                                               ("memory/memory.limit_in_bytes", "memory/memory.usage_in_bytes",
                                                "memory/memory.stat", "total_inactive_file")):
        try:
            text = (root / limit_f).read_text().strip()
            if text == "max" or int(text) >= _NO_LIMIT:
                continue
            usage = int((root / usage_f).read_text())
            stat = dict(line.split() for line in (root / stat_f).read_text().splitlines() if line.count(" ") == 1)
            return max(0, int(text) - usage + int(stat.get(inactive, 0)))
        except (OSError, ValueError):
            continue
    return math.inf


def _address_space_room() -> float:
    """Bytes this process may still map under its address-space limit (RLIMIT_AS); infinite without one."""
    import resource

    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    if soft == resource.RLIM_INFINITY:
        return math.inf
    try:
        vm = next(int(line.split()[1]) * 1024 for line in open("/proc/self/status") if line.startswith("VmSize:"))
    except (OSError, StopIteration, ValueError):
        return soft
    return max(0, soft - vm)


def free_disk(path: str | os.PathLike) -> int:
    """Free bytes of the file system that will hold ``path`` (its nearest existing ancestor)."""
    import shutil

    p = Path(local_path(path)).resolve()
    while not p.exists() and p != p.parent:
        p = p.parent
    return int(shutil.disk_usage(p).free)


def _partial_bytes(out) -> int:
    """Bytes already on disk in the ``.partial`` store of ``out`` (a resume needs only the rest)."""
    from .objstore import partial_path

    part = partial_path(out)
    return sum(f.stat().st_size for f in part.rglob("*") if f.is_file()) if part.is_dir() else 0


def sample_bytes(arrays) -> int:
    """Raw bytes of one sample over ``arrays`` (name -> ArraySpec)."""
    import numpy as np

    return sum(math.prod(a.shape) * np.dtype(a.dtype).itemsize for a in arrays.values())


def check_store_size(out, n: int, chunk: int, arrays) -> int:
    """Refuse a store whose chunk task cannot fit in memory or whose data cannot fit on disk.

    Args:
        out: the output path (its file system is checked).
        n: samples; chunk: samples per chunk; arrays: name -> ArraySpec.

    Returns:
        the estimated peak bytes of one chunk task.
    """
    per = sample_bytes(arrays)
    task = chunk * per * TASK_FACTOR  # not min(chunk, n): zarr allocates a whole chunk to write a partial one
    mem = available_memory()
    if task > mem:
        raise ConfigError(f"chunk {chunk} needs about {task / GiB:.1f} GiB per task ({per / 2**20:.2f} MiB per sample "
                          f"x {TASK_FACTOR} while assembling and compressing), more than the {mem / GiB:.1f} GiB of "
                          "memory available; lower the chunk")
    from .objstore import is_object_url

    if is_object_url(out):  # a bucket has no free-space figure to check against
        return task
    need, free = n * per / EXPECTED_COMPRESSION - _partial_bytes(out), free_disk(out)
    if need > free:
        raise ConfigError(f"{n} samples need about {need / GiB:.3g} GiB of disk ({per / 2**20:.2f} MiB raw per "
                          f"sample, compressed about {EXPECTED_COMPRESSION}x as real stores measure), more than "
                          f"the {free / GiB:.1f} GiB free under {Path(local_path(out)).resolve().parent}; make fewer "
                          "samples or free some space")
    return task


def check_workers(workers: int, task_bytes: int = 0) -> None:
    """Refuse more local worker processes than the available memory holds (each: WORKER_BYTES + one task)."""
    per = WORKER_BYTES + int(task_bytes)
    mem = available_memory()
    if workers * per > mem:
        raise ConfigError(f"--workers {workers} needs about {workers * per / GiB:.1f} GiB ({per / 2**20:.0f} MiB per "
                          f"worker process), more than the {mem / GiB:.1f} GiB of memory available; use at most "
                          f"{max(1, mem // per)} workers")
