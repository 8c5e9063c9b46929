"""Data-parallel training on torch.distributed: the world of this process, the launcher, failures.

``svtrain fit --nproc N`` resolves and checks the config, then starts N copies of ``python -m train.cli fit`` through
torch's elastic launcher (:func:`launch`, the engine behind ``torchrun``); ``torchrun --nproc-per-node N -m
train.cli fit ...`` (or ``--nnodes`` across machines) starts the same workers. A worker finds its rank in the
environment the launcher sets (RANK, WORLD_SIZE, LOCAL_RANK) and joins the process group: NCCL on CUDA, gloo
otherwise. The model is wrapped in DistributedDataParallel, whose gradient all-reduce averages the ranks' gradients.

What makes N processes train like one (tests/test_train_distributed.py holds it):

- the global batch of step t is the sample positions [t·G, (t+1)·G) and rank r takes the r-th block of
  G / world of them (``train.data.StepSampler``): a pure function of (seed, step, rank);
- every rank draws the loss configurations of the *whole* global batch from the same generator and keeps its rows
  (``LossConfigs.rows``), so the generator state is the same on every rank and one checkpoint holds it;
- the network normalises per sample (instance norm, no BatchNorm: ``train.net``), so a sample's output does not
  depend on which other samples share its rank's batch;
- the logged loss is the mean over ranks; gradient clipping sees the all-reduced gradients, the same on every rank.

Dropout masks come from per-rank streams (a rank's torch RNG), whose states rank 0 gathers into each checkpoint.
Rank 0 alone writes checkpoints, metrics and the loss curve. The learning rate is used as given whatever the world
size (see ``ComputeConfig.global_batch``).

Failures: a worker that loses its peers (a killed rank closes its gloo/NCCL connections) raises :class:`PeerLost`.
Under ``--nproc`` the workers report errors to the launcher through files instead of the console, and the launcher
prints one line naming the rank that failed first and the last checkpoint to resume from; the elastic agent stops
the surviving ranks, so nothing hangs. ``SVTRAIN_PAUSE_AT_STEP=r:s:file`` makes rank r sleep before step s (fault
injection for the tests, which kill it there; see :func:`pause_hook`).
"""
from __future__ import annotations

import contextlib
import datetime
import logging
import os
import signal
import sys
import tempfile
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

import torch
import torch.distributed as dist
import yaml

from svcore.errors import ConfigError, SvgenError
from svcore.log import get_logger

log = get_logger(__name__)

#: set in the workers that ``svtrain fit --nproc`` starts: the folder where they leave their error lines.
ERROR_DIR_ENV = "SVTRAIN_ERROR_DIR"
#: fault injection: "rank:step" -> that rank sleeps before that step.
PAUSE_ENV = "SVTRAIN_PAUSE_AT_STEP"
#: collective timeout: a peer that is alive but stuck fails the run after this long instead of hanging it forever.
TIMEOUT = datetime.timedelta(minutes=10)


class PeerLost(SvgenError):
    """Another rank of the run died or became unreachable."""


class Interrupted(SvgenError):
    """The launcher was stopped by a signal (Ctrl-C): exit status 130 like an interrupted single process."""

    exit_code = 130


@dataclass(frozen=True)
class World:
    """This process's place in a data-parallel run (a single process: rank 0 of 1).

    Attributes:
        rank: global rank. size: number of processes. local_rank: rank on this machine (picks the GPU).
        local_size: processes on this machine (what its GPUs must hold).
    """

    rank: int = 0
    size: int = 1
    local_rank: int = 0
    local_size: int = 1

    @property
    def main(self) -> bool:
        """Rank 0: the one process that writes files."""
        return self.rank == 0

    def batches(self, batch_size: int, global_batch: int = 0) -> tuple[int, int]:
        """(global batch, this rank's batch): ``batch_size`` per rank unless ``global_batch`` is given.

        Raises:
            ConfigError: a global batch that the ranks cannot split evenly.
        """
        g = global_batch or batch_size * self.size
        if g % self.size:
            raise ConfigError(f"--global-batch {g} does not split over {self.size} processes; "
                              f"use a multiple of {self.size}")
        return g, g // self.size


def world_from_env() -> World:
    """The world a launcher (``svtrain fit --nproc``, torchrun) put this process in; rank 0 of 1 otherwise."""
    size = int(os.environ.get("WORLD_SIZE", "1"))
    if size <= 1:
        return World()
    return World(int(os.environ["RANK"]), size, int(os.environ.get("LOCAL_RANK", "0")),
                 int(os.environ.get("LOCAL_WORLD_SIZE", str(size))))


def check_world(nproc: int, device: torch.device) -> None:
    """Refuse a data-parallel width the machine cannot hold (before anything is launched).

    Raises:
        ConfigError: CUDA with more processes than GPUs; one explicit cuda:N for several processes; MPS.
    """
    if nproc <= 1:
        return
    if device.type == "cuda":
        n = torch.cuda.device_count()
        if nproc > n:
            raise ConfigError(f"--nproc {nproc} needs {nproc} CUDA devices (one per process); this machine has {n}")
    elif device.type == "mps":
        raise ConfigError("--nproc > 1 is not supported on mps (torch.distributed has no MPS backend); "
                          "use --nproc 1 or --device cpu")


@contextlib.contextmanager
def process_group(world: World, device: torch.device):
    """Join the process group for the duration of a run (no-op for a single process)."""
    if world.size <= 1:
        yield
        return
    if device.type == "cuda":
        torch.cuda.set_device(device)
    backend = "nccl" if device.type == "cuda" else "gloo"
    dist.init_process_group(backend, timeout=TIMEOUT, **({"device_id": device} if backend == "nccl" else {}))
    try:
        yield
    finally:
        with contextlib.suppress(Exception):
            dist.destroy_process_group()


def mean_over_ranks(x: float, world: World, device: torch.device) -> float:
    """The mean of a per-rank scalar over all ranks (the logged loss of the global batch)."""
    if world.size <= 1:
        return x
    t = torch.tensor([x], dtype=torch.float64, device=device)
    dist.all_reduce(t)
    return float(t.item()) / world.size


def gather(obj, world: World) -> list:
    """Every rank's ``obj`` (a list indexed by rank) on every rank."""
    if world.size <= 1:
        return [obj]
    out = [None] * world.size
    dist.all_gather_object(out, obj)
    return out


def broadcast(obj, world: World):
    """Rank 0's ``obj`` on every rank (a checkpoint read by rank 0 alone: no shared file system needed)."""
    if world.size <= 1:
        return obj
    box = [obj]
    dist.broadcast_object_list(box, src=0)
    return box[0]


def pause_hook(world: World, step: int) -> None:
    """Fault injection (``SVTRAIN_PAUSE_AT_STEP=rank:step:marker``): that rank writes its pid to the file ``marker``
    and sleeps before that step (its peers then wait in the step's all-reduce)."""
    spec = os.environ.get(PAUSE_ENV)
    if spec:
        r, s, marker = spec.split(":", 2)
        if int(r) == world.rank and int(s) == step:
            Path(marker).write_text(str(os.getpid()))
            time.sleep(3600)


def is_collective_failure(e: BaseException) -> bool:
    """Does this exception say that a peer is gone (closed connection, timeout, aborted communicator)?"""
    if isinstance(e, getattr(dist, "DistError", ())):
        return True
    msg = str(e).lower()
    return isinstance(e, RuntimeError) and any(w in msg for w in ("gloo", "nccl", "connection", "timed out",
                                                                 "peer", "socket"))


def report_to_launcher(e: SvgenError) -> bool:
    """Under ``svtrain fit --nproc``: leave the error line for the launcher (which prints one line for the whole run)
    instead of printing it here. Returns whether it was left."""
    d = os.environ.get(ERROR_DIR_ENV)
    if not d:
        return False
    rank = int(os.environ.get("RANK", "0"))
    kind = "peer" if isinstance(e, PeerLost) else "error"
    (Path(d) / f"rank{rank}.{kind}").write_text(str(e).splitlines()[0] if str(e) else type(e).__name__)
    return True


def last_checkpoint_note(out: Path) -> str:
    """Where a stopped run can resume from, in words."""
    ck = out / "checkpoint.pt"
    if not ck.is_file():
        return f"no checkpoint was written in {out} yet (rerun to start over)"
    try:
        step = torch.load(ck, map_location="cpu", weights_only=True, mmap=True).get("step")
    except Exception:  # a checkpoint that cannot be read is reported by the resume itself
        step = "?"
    return f"the last checkpoint ({ck}) is at step {step}: rerun the same command to resume"


def _describe(rank: int, failure, error_dir: Path, n: int) -> tuple[int, str]:
    """(priority, text) of one failed rank: its own error line first, then deaths by signal, then exit codes;
    a rank that only lost its peers is the least informative."""
    for kind, prio in (("error", 0), ("peer", 3)):
        f = error_dir / f"rank{rank}.{kind}"
        if f.is_file():
            return prio, f"rank {rank} of {n}: {f.read_text().strip()}"
    code = failure.exitcode
    if code is not None and code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        return (2 if name == "SIGTERM" else 1), f"rank {rank} of {n} was killed by {name}"
    return 2, f"rank {rank} of {n} exited with code {code}"


def launch_checked(cfg, out: str | Path, resume: bool | str) -> None:
    """``svtrain fit --nproc N``: every check a worker would make (device, precision, world, global batch, the data
    source) runs here first, so bad input is one line from one process, then :func:`launch`."""
    from .data import open_source, split_for
    from .device import placement

    place = placement(cfg.compute.device, cfg.compute.precision, 0 if cfg.compute.nproc > 1 else None)
    check_world(cfg.compute.nproc, place.device)
    World(0, cfg.compute.nproc).batches(cfg.optim.batch_size, cfg.compute.global_batch)
    split_for(open_source(cfg.data), cfg.data)
    launch(cfg, out, cfg.compute.nproc, resume)


def write_worker_params(cfg, path: Path) -> Path:
    """The params file the launched workers train from (``svtrain fit --params PATH``): a ``train:`` section with
    the preset's name (for their provenance) and every resolved value, ``compute.nproc`` set to 1 (a worker is one
    rank: it must not launch again). ``train.config.resolve(None, path)`` reads back the same config."""
    values = cfg.to_dict()
    values["compute"]["nproc"] = 1
    path.write_text(yaml.safe_dump({"train": {"config_preset": cfg.preset, **values}}, sort_keys=False))
    return path


def launch(cfg, out: str | Path, nproc: int, resume: bool | str) -> None:
    """Run ``svtrain fit`` in ``nproc`` processes on this machine through torch's elastic launcher.

    The resolved config travels as a params file, so every rank trains exactly the config checked here.

    Raises:
        SvgenError: one line naming the rank that failed first and the checkpoint to resume from.
    """
    from torch.distributed.elastic.multiprocessing.api import SignalException
    from torch.distributed.elastic.multiprocessing.errors import ChildFailedError
    from torch.distributed.launcher.api import LaunchConfig, elastic_launch

    out = Path(out)
    with tempfile.TemporaryDirectory(prefix="svtrain-launch-") as tmp:
        params = write_worker_params(cfg, Path(tmp) / "params.yaml")
        errors = Path(tmp) / "errors"
        errors.mkdir()
        args = ["-m", "train.cli", "fit", "--params", str(params), "--out", str(out)] + (
            ["--no-resume"] if not resume else ["--resume-if-unchanged"] if resume == "if-unchanged" else [])
        config = LaunchConfig(min_nodes=1, max_nodes=1, nproc_per_node=nproc, run_id=f"svtrain-{uuid.uuid4().hex[:8]}",
                              rdzv_backend="c10d", rdzv_endpoint="localhost:0", max_restarts=0, monitor_interval=0.2)
        env = {ERROR_DIR_ENV: str(errors)}
        if "OMP_NUM_THREADS" not in os.environ and not cfg.optim.threads:
            env["OMP_NUM_THREADS"] = "1"  # as torchrun: N processes with all cores each oversubscribe the machine
        old = {k: os.environ.get(k) for k in env}
        os.environ.update(env)
        # the agent's own warnings would add lines to our one-line error (its loggers set their own levels)
        quiet = [logging.getLogger(n) for n in list(logging.root.manager.loggerDict)
                 if n.startswith("torch.distributed")] + [logging.getLogger("torch.distributed")]
        levels = [q.level for q in quiet]
        for q in quiet:
            q.setLevel(logging.CRITICAL)
        try:
            elastic_launch(config, entrypoint=sys.executable)(*args)
        except ChildFailedError as e:
            ranked = sorted(_describe(r, f, errors, nproc) + (r,) for r, f in e.failures.items())
            raise SvgenError(f"{ranked[0][1]}; the other ranks were stopped; "
                             f"{last_checkpoint_note(out)}") from None
        except SignalException as e:  # Ctrl-C / SIGTERM of the launcher: the agent has stopped the workers
            raise Interrupted(f"stopped by {signal.Signals(e.sigval).name}; {last_checkpoint_note(out)}") from None
        finally:
            for q, lv in zip(quiet, levels):
                q.setLevel(lv)
            for k, v in old.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
