"""``timing.json``: what a run measured of its machine and moment, beside the outputs DVC hashes.

Every file the fit stage declares in dvc.yaml (model, checkpoint, config, metrics, curves, provenance) is a function
of the code, the params and the data alone, so that a fresh clone's ``dvc repro`` writes the same bytes and leaves
dvc.lock as committed (issue #40). What differs from one machine, checkout or run to the next is written here, to a
file dvc.yaml does not declare: DVC neither hashes nor caches it (an output marked ``cache: false`` would still be
hashed into dvc.lock), and git ignores runs/. It holds:

- the training clock: wall and CPU seconds of training (held-out evaluation left out) and this call's it/s;
- the held-out curve's times (heldout.csv holds its steps and errors): the time of each evaluation, by step;
- the step a resumed run continued from (None: from scratch);
- this machine's view of the run: the store's absolute path and the running svgen (package version with its
  commit, and the code digest).

A checkpoint writes it beside itself with the same step, so a resumed run continues the clock from there; a
checkpoint without its timing.json (restored by DVC, copied without it) restarts the clock at 0, and
``clock_from_step`` says from which step the times count.
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

FILE = "timing.json"
#: the keys of a fit's result (what ``svtrain fit`` prints) that come from this file, not from metrics.json
KEYS = ("it_per_s", "train_wall_s", "train_cpu_s", "resumed_from")


def losses_digest(losses: list[float]) -> str:
    """sha256 of a run's losses so far: which trajectory a checkpoint (and the timing.json beside it) belongs to."""
    return hashlib.sha256(json.dumps([float(v) for v in losses]).encode()).hexdigest()


def write(run_dir: str | os.PathLike, info: dict) -> Path:
    """Write ``run_dir/timing.json`` atomically (a kill mid-write leaves the previous file)."""
    path = Path(run_dir) / FILE
    tmp = path.with_name(FILE + ".tmp")
    tmp.write_text(json.dumps(info, indent=2) + "\n")
    os.replace(tmp, path)
    return path


def read(run_dir: str | os.PathLike) -> dict:
    """``run_dir/timing.json``, or {} when there is none (or it is unreadable: it records, it decides nothing)."""
    try:
        info = json.loads((Path(run_dir) / FILE).read_text())
    except (OSError, ValueError):
        return {}
    return info if isinstance(info, dict) else {}


def continued(run_dir: str | os.PathLike, step: int, losses: list[float], state: dict | None = None) -> dict:
    """The clock a run resumed at ``step`` continues from: the timing.json written with that checkpoint (same step
    and losses), else the clock a checkpoint from before this file recorded (``state``), else zero from ``step``.

    Returns:
        {"train_wall_s", "train_cpu_s", "heldout": {step: {"wall_s", "cpu_s"}}, "clock_from_step"}.
    """
    info = read(run_dir)
    if info.get("checkpoint") == {"step": step, "losses_sha256": losses_digest(losses)}:
        return {"train_wall_s": float(info.get("train_wall_s") or 0.0),
                "train_cpu_s": float(info.get("train_cpu_s") or 0.0),
                "heldout": {int(r["step"]): {"wall_s": r["wall_s"], "cpu_s": r["cpu_s"]}
                            for r in info.get("heldout", [])},
                "clock_from_step": int(info.get("clock_from_step", 0))}
    state = state or {}
    if "train_clock" in state:  # a checkpoint written before timing.json existed kept its clock itself
        wall, cpu = state["train_clock"]
        return {"train_wall_s": float(wall), "train_cpu_s": float(cpu), "clock_from_step": 0,
                "heldout": {int(r["step"]): {"wall_s": r["wall_s"], "cpu_s": r["cpu_s"]}
                            for r in state.get("heldout", []) if "cpu_s" in r}}
    return {"train_wall_s": 0.0, "train_cpu_s": 0.0, "heldout": {}, "clock_from_step": step}


def where(store: str | None) -> dict:
    """This machine's view of a run: the store's absolute path (an object-store URL as given) and the running svgen
    (package version, which names the commit, and the code digest)."""
    from svcore.versions import git_description, svgen_version
    from storage.objstore import is_object_url, local_path

    resolved = None if store is None else (
        str(store) if is_object_url(store) else str(Path(local_path(store)).resolve()))
    return {"store_resolved": resolved, "svgen": svgen_version(), "git": git_description()}
