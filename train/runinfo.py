"""Where a run's training store is, recorded so that the run is usable from any working directory.

A run's config keeps ``data.store`` as the user spelled it (often relative to the project, e.g.
``data/renders.zarr``: what params.yaml and DVC say). ``svtrain fit`` also writes ``run.json`` into the run
directory with the store's path relative to the run directory, which holds from anywhere and when the project
is moved as a whole. ``svtrain eval`` finds the store through it where it needs the store: for its held-out split,
or for the baselines' means of a run from before ``svtrain fit`` recorded them with the model.

Also what a run records of itself so that its files are the same bytes on any machine and checkout: its config less
the machine's settings (:func:`recorded_config`), its code as the digest of what training can run
(:func:`code_digest`, :func:`run_versions`), and the key a checkpoint must match to be continued (:func:`resume_key`).
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from svcore import versions
from svcore.errors import ConfigError, StoreError

RUN_FILE = "run.json"


def record(run_dir: str | os.PathLike, store: str | None) -> None:
    """Write ``run_dir/run.json``: the training store as given and relative to the run directory."""
    from storage.objstore import is_object_url, local_path, normalize_url

    run = Path(run_dir)
    # an object-store URL is the same from anywhere: recorded as it is
    info = {"train_store": None if store is None else
            {"as_given": str(store), "from_run": normalize_url(str(store)) if is_object_url(store) else
             os.path.relpath(Path(local_path(store)).resolve(), run.resolve())}}
    tmp = run / (RUN_FILE + ".tmp")
    tmp.write_text(json.dumps(info, indent=1) + "\n")
    os.replace(tmp, run / RUN_FILE)


#: the module whose import closure is a run's code (:func:`code_digest`): what ``svtrain fit`` can run to train
CODE_OF = "train.fit"
#: config keys a run does not record (config.yaml, the checkpoint's and the model's config): settings of the machine
#: that change no result, read from the environment (SVGEN_WORKERS), so that they change no byte DVC hashes
MACHINE_KEYS = (("data", "workers"),)


def code_digest() -> str:
    """sha256 of the training code: the source :data:`CODE_OF` can import (:func:`svcore.versions.closure_digest`),
    the code half of :func:`resume_key` and what a run records as its code. A change elsewhere (the gallery,
    ``svtrain predict``) is no other run; the package version and the commit are not part of it."""
    return versions.closure_digest(CODE_OF)


def run_versions() -> dict[str, str]:
    """What a run records of the code that trained it (provenance.json, model.pt): the libraries' installed
    versions and ``svgen`` as ``"code DIGEST"``, the digest of the training code (:func:`code_digest`), as stores
    record theirs (:func:`svcore.versions.store_versions`): no package version, which names the commit."""
    return versions.store_versions(CODE_OF)


def recorded_config(cfg) -> dict:
    """The config as a run records it: :meth:`Config.to_dict` less :data:`MACHINE_KEYS` (a recorded config reads
    back with their defaults, and a rerun takes them from its own machine)."""
    conf = cfg.to_dict()
    for section, key in MACHINE_KEYS:
        conf[section] = {k: v for k, v in conf[section].items() if k != key}
    return conf


def config_text(cfg) -> str:
    """config.yaml: :func:`recorded_config` as a params file (``train:`` and every key but the machine's), which
    ``svtrain fit --params`` reads back to this config."""
    import yaml

    return yaml.safe_dump({cfg.SECTION: recorded_config(cfg)}, sort_keys=False)


def resume_key(cfg, data: dict) -> str:
    """What a checkpoint must have been trained from for ``svtrain fit --resume-if-unchanged`` to continue it:
    the resolved config (less the store's spelling and the loader's worker count, which do not change a step's
    result, nor do the loader's memory budget and the checkpoint interval), the training data's identity (``data``:
    a store's kind, config hash and size, or the synthetic source's settings; :func:`train.fit.provenance`) and
    :func:`code_digest` (the training code: an edit to code training cannot run continues the checkpoint).

    DVC reruns the fit stage when its params, store or code change, and also when a killed run left no model:
    only the second case may continue the checkpoint it finds.
    """
    conf = cfg.to_dict()
    conf["data"] = {k: v for k, v in conf["data"].items() if k not in ("store", "workers", "loader_memory_mib")}
    conf["optim"] = {k: v for k, v in conf["optim"].items() if k != "checkpoint_minutes"}
    ident = data_identity(data)
    blob = json.dumps({"config": conf, "data": ident, "code": code_digest()}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()


#: config keys a plain resume may see changed: ``optim.iterations`` (continue a run further), the store's spelling
#: (its identity is compared instead), machine settings that change no step's result, and the batch per process
#: (the global batch, which decides the data order, is checked by train.fit.Trainer.load).
RESUMABLE_KEYS = frozenset({"optim.iterations", "data.store", "data.workers", "optim.threads", "compute.device",
                            "compute.nproc", "compute.global_batch", "optim.batch_size", "data.loader_memory_mib",
                            "optim.checkpoint_minutes"})


def _flat(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        out.update(_flat(v, f"{prefix}{k}.") if isinstance(v, dict) else {prefix + k: v})
    return out


def data_identity(data: dict) -> dict:
    """What identifies a run's training data (:func:`train.fit.provenance`'s ``data`` less the store's spelling)."""
    return {k: v for k, v in data.items() if k not in ("store", "store_resolved")}


def describe_data(data: dict | None) -> str:
    """A run's training data in a few words: a store by path, kind, size and config hash, or the synthetic source."""
    if not data:
        return "unrecorded data"
    if "synthetic" in data:
        return "the synthetic demo source"
    return (f"store {data.get('store')} ({data.get('kind')}, {data.get('n')} samples, config hash "
            f"{data.get('config_hash')})")


def resume_changes(state: dict, cfg, data: dict) -> list[str]:
    """What differs between a checkpoint and this run beyond :data:`RESUMABLE_KEYS`: ``key old -> new`` for each
    config key, and the data when its identity differs (checkpoints from before it was recorded: config only).

    A key added to the config since the checkpoint was written counts as its default there (a new key's default
    is the behaviour from before it existed), so adding a key does not make every earlier run unresumable."""
    from train.config import from_dict

    try:
        recorded = from_dict(state["config"]).to_dict()
    except ConfigError:  # a config this code no longer validates: compare it as written (every difference shows)
        recorded = state["config"]
    old, new = _flat(recorded), _flat(cfg.to_dict())
    changed = [f"{k} {old.get(k)!r} -> {new.get(k)!r}" for k in sorted(set(old) | set(new))
               if k not in RESUMABLE_KEYS and old.get(k) != new.get(k)]
    if "data" in state and data_identity(state["data"]) != data_identity(data):
        changed.insert(0, f"data {describe_data(state['data'])} -> {describe_data(data)}")
    return changed


def run_dir_of(checkpoint_path: str | os.PathLike) -> Path:
    p = Path(checkpoint_path)
    return p if p.is_dir() else p.parent


def train_store(checkpoint_path: str | os.PathLike, store: str | None, override: str | None = None,
                need: str = "its baselines use the training split's means") -> str | None:
    """The training store of a run, as a path valid from the current directory (None: synthetic source).

    Tried in order: ``override`` (``--train-store``); the recorded path relative to the run directory; the path
    as given, if absolute or found from here. ``need``: why the caller needs it (the error says so).

    Raises:
        StoreError: the run trained on a store and none of these finds it.
    """
    if override:
        return str(override)
    if store is None:
        return None
    from storage.objstore import is_object_url

    if is_object_url(store):
        return str(store)
    run = run_dir_of(checkpoint_path)
    tried = []
    try:
        rel = json.loads((run / RUN_FILE).read_text())["train_store"]["from_run"]
        tried.append(run / rel)
    except (OSError, ValueError, KeyError, TypeError):
        pass
    tried.append(Path(store))
    for p in tried:
        if p.exists() or Path(str(p) + ".partial").exists():
            return str(p)
    raise StoreError(f"eval needs the run's training store ({need}): {store!r} is not found from {os.getcwd()} "
                     f"nor relative to the run directory {run}; pass --train-store PATH")


def device_memory(device=None, local_size: int = 1) -> tuple[int, str] | None:
    """Bytes a process may allocate on ``device`` and where, in words: the CPU's available memory shared by the
    ``local_size`` processes of this machine (:func:`storage.bounds.available_memory`), a CUDA device's free memory;
    None for other devices (not checked)."""
    from storage.bounds import available_memory

    kind = getattr(device, "type", "cpu")
    if kind == "cpu":
        return available_memory() // max(1, local_size), "of memory available"
    if kind == "cuda":
        import torch

        return torch.cuda.mem_get_info(device)[0], f"free on {device}"
    return None


#: activation bytes kept per pixel and channel of an encoder level through forward and backward (float32 value,
#: gradient, norm and activation copies, the decoder's mirror level and skip concatenation): a generous estimate.
ACT_FACTOR = 8 * 4


def check_run(cfg, out_dir: str | os.PathLike, n_train: int, global_batch: int | None = None,
              rank_batch: int | None = None, device=None, local_size: int = 1) -> None:
    """Refuse, before the run directory is made, what cannot work: an output inside the training store, a global
    batch larger than the training split, a rank's batch whose activations cannot fit in its device's memory.

    Args:
        global_batch, rank_batch: samples per step over all ranks and on this rank (default: optim.batch_size).
        device: the rank's torch device (None or CPU: host memory shared by the ``local_size`` processes of this
            machine; CUDA: that GPU's free memory; other devices are not checked).

    Raises:
        ConfigError / StoreError: one line naming the limit.
    """
    from storage.store import refuse_inside
    from svcore.errors import ConfigError

    refuse_inside(out_dir, cfg.data.store)
    g = cfg.optim.batch_size if global_batch is None else global_batch
    b = cfg.optim.batch_size if rank_batch is None else rank_batch
    name = "optim.batch_size" if g == cfg.optim.batch_size else "the global batch"
    if g > n_train:
        raise ConfigError(f"{name} {g} is larger than the {n_train} training samples of the split; "
                          f"use at most {n_train}")
    m, crop = cfg.model, cfg.data.crop
    per_sample = ACT_FACTOR * sum(w * (crop >> i) ** 2 for i, w in enumerate(m.widths()))
    free = device_memory(device, local_size)
    if free is None:
        return
    mem, where = free
    if b * per_sample > mem:
        raise ConfigError(f"a batch of {b} per process needs about {b * per_sample / 2**30:.1f} GiB of activations at "
                          f"crop {crop} ({per_sample / 2**20:.0f} MiB per sample), more than the "
                          f"{mem / 2**30:.1f} GiB {where}; use at most {max(1, mem // per_sample)}")
