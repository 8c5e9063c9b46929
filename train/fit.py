"""``svtrain fit``: the training loop, checkpoints that resume bit-for-bit, metrics and the loss curve.

Resume equivalence: everything random is either a pure function of (seed, step) (the batches, see
``train.data``) or a generator whose state is checkpointed (loss configurations: ``loss_rng``;
dropout: torch's global RNG). So stopping at any checkpoint and resuming reproduces the
uninterrupted run exactly on the same machine and thread count.

Devices and precision come from ``cfg.compute`` (train/device.py); under a data-parallel launcher each process is
one rank (train/distributed.py) and rank 0 alone writes. :class:`Trainer` is the loop itself: ``fit`` adds
checkpoints, progress and outputs around it, and the benchmarks iterate the same object.

Outputs in the run directory: ``config.yaml`` (the resolved config as a params file with a ``train:`` section),
``checkpoint.pt`` (full state), ``model.pt`` (weights + config + provenance), ``provenance.json`` (data source, config
preset, library versions and the digest of the training code, and the training split's map means that ``svtrain
eval``'s baselines use, so that evaluating a model needs no copy of its training store), ``metrics.json`` (what the
run gave), ``fit_metrics.json`` (the few numbers `dvc metrics` shows), ``loss.csv``, ``loss.png``, ``heldout.csv``.
These are DVC outputs: the same code, params and data write the same bytes on any machine, checkout, date and
working directory. The clock (it/s, training wall and CPU seconds, the held-out curve's times), the store's absolute
path and the package version go to ``timing.json`` (train/timing.py), which DVC does not hash.
"""
from __future__ import annotations

import contextlib
import json
import math
import time
from pathlib import Path
from typing import Iterator

import numpy as np
import torch

from svcore.errors import ConfigError, SvgenError
from svcore.log import get_logger
from svcore.progress import progress
from svcore.seeds import stream_seed

from . import checkpoint, dvc_metrics, heldout, loader_memory, runinfo, timing
from .config import Config, OptimConfig, drop_retired
from .data import PairDataset, make_loader, open_source, split_for
from .device import Placement, placement
from .distributed import (PeerLost, World, broadcast, check_world, gather, is_collective_failure,
                          last_checkpoint_note, mean_over_ranks, pause_hook, process_group, world_from_env)
from .evaluate import MEANS_KEY, fit_means
from .heldout import HeldoutProbe, TrainClock
from .brdf import SPECULAR
from .loss import LossConfigs, make_loss, sample_configs
from .net import SVBRDFNet, count_parameters

log = get_logger(__name__)


def build(cfg: Config) -> tuple[SVBRDFNet, torch.optim.Optimizer, torch.Generator]:
    """Fresh model (seeded init, or the weights of ``optim.init``), Adam, and the loss-configuration generator."""
    o = cfg.optim
    torch.manual_seed(stream_seed(o.seed, "train.init"))
    model = SVBRDFNet(cfg.model)
    start = checkpoint.init_weights(o.init, cfg.model)  # fine-tuning: the seeded draw above still happens (same RNG streams)
    if start is not None:
        model.load_state_dict(start)
    opt = torch.optim.Adam(model.parameters(), lr=o.lr, betas=(o.beta1, o.beta2))
    gen = torch.Generator().manual_seed(stream_seed(o.seed, "train.loss_configs"))
    torch.manual_seed(stream_seed(o.seed, "train.dropout"))
    return model, opt, gen


def provenance(cfg: Config, src) -> dict:
    """What a run trained on and with: the config preset, the data source (a renders store's path as given, kind,
    config hash and size, or the synthetic source's settings) and the versions (:func:`train.runinfo.run_versions`:
    the libraries' and the digest of the training code, as stores record theirs). Nothing of the machine or the
    checkout: the store's absolute path and the package version go to timing.json (:func:`train.timing.where`)."""
    if cfg.data.store:
        meta = getattr(src, "attrs", {}).get("svgen", {})
        data = {"store": str(cfg.data.store), "kind": meta.get("kind"), "config_hash": meta.get("config_hash"),
                "n": meta.get("n")}
    else:  # the source actually used (a caller may pass its own), not the config's synthetic_* defaults
        data = {"synthetic": {k: getattr(src, a, None) for k, a in (("samples", "n"), ("size", "size"),
                                                                    ("materials", "n_materials"), ("seed", "seed"),
                                                                    ("kind", "kind"))}}
    return {"config_preset": cfg.preset, "data": data, "versions": runinfo.run_versions()}


def lr_at(o: OptimConfig, step: int) -> float:
    """Learning rate of step ``step`` (0-based) of a run of ``o.iterations`` steps."""
    if o.schedule == "constant" or o.iterations <= 1:
        return o.lr
    t = min(step, o.iterations - 1) / (o.iterations - 1)
    return o.lr * (o.lr_final + (1.0 - o.lr_final) * 0.5 * (1.0 + math.cos(math.pi * t)))


def normal_term(pred: torch.Tensor, maps: torch.Tensor, kind: str = "l2") -> torch.Tensor:
    """The normal term's value (``optim.normal_loss``) on (B, 10, H, W) packed maps: mean squared error of the x, y
    components ("l2"), or the mean over samples of each sample's RMSE in the (n+1)/2 encoding ("rmse": what
    ``svtrain eval`` reports; unlike a pooled squared error it weighs a sample's error by 1 / its RMSE, so relief
    predicted on a flat material costs much)."""
    p, t = pred[:, 0:3], maps[:, 0:3]
    if kind == "rmse":
        # 1e-8 under the root: a finite gradient at a perfect prediction (RMSE ~ 1e-4 at worst, far below the data's)
        return (((p - t) * 0.5) ** 2).mean((1, 2, 3)).add(1e-8).sqrt().mean()
    return ((p[:, 0:2] - t[:, 0:2]) ** 2).mean()


def spec_grad_term(pred: torch.Tensor, maps: torch.Tensor) -> torch.Tensor:
    """The specular texture term's value (``optim.spec_grad``) on (B, 10, H, W) packed maps: mean absolute
    difference of the specular map's neighbour differences (rows and columns), predicted against true. A grey,
    constant true specular makes every texture in the predicted one cost; its mean level costs nothing (``map_l1``
    weighs the level)."""
    p, t = pred[:, SPECULAR], maps[:, SPECULAR]
    return (((p[..., 1:, :] - p[..., :-1, :]) - (t[..., 1:, :] - t[..., :-1, :])).abs().mean()
            + ((p[..., 1:] - p[..., :-1]) - (t[..., 1:] - t[..., :-1])).abs().mean()) / 2


def normal_form(o: OptimConfig, step: int | None) -> tuple[float, str]:
    """(weight, form) of the normal term at 0-based ``step``: ``normal_late_*`` from ``normal_late_from`` of the run
    on, else ``normal_l2`` and ``normal_loss`` (``step`` None: the first form)."""
    if o.normal_late_loss is not None and step is not None and step >= o.normal_late_from * o.iterations:
        return o.normal_late_weight, o.normal_late_loss
    return o.normal_l2, o.normal_loss


def loss_terms(pred: torch.Tensor, maps: torch.Tensor, loss_fn, gen: torch.Generator, o: OptimConfig,
               configs: LossConfigs | None = None, step: int | None = None) -> torch.Tensor:
    """The training loss: ``render_weight`` x the rendering loss + ``map_l1`` x L1 on the packed maps + the normal
    term (:func:`normal_form` at ``step``); a term of weight 0 is not computed (the L1 arm renders nothing).

    Args:
        pred, maps: (B, 10, H, W) float32 predicted and target packed maps.
        step: 0-based step of the run (selects the late normal term; None: the first form).
    """
    terms = []
    if o.render_weight > 0:
        r = loss_fn(pred, maps, gen, configs)
        terms.append(r if o.render_weight == 1.0 else o.render_weight * r)
    if o.map_l1 > 0:
        terms.append(o.map_l1 * (pred - maps).abs().mean())
    if o.spec_grad > 0:
        terms.append(o.spec_grad * spec_grad_term(pred, maps))
    weight, form = normal_form(o, step)
    if weight > 0:
        terms.append(weight * normal_term(pred, maps, form))
    return sum(terms[1:], terms[0])  # config validation guarantees at least one term


def train_step(model: torch.nn.Module, opt: torch.optim.Optimizer, loss_fn, image: torch.Tensor, maps: torch.Tensor,
               gen: torch.Generator, o: OptimConfig, step: int, *, place: Placement | None = None,
               scaler: torch.amp.GradScaler | None = None, configs: LossConfigs | None = None) -> tuple[float, float]:
    """One optimisation step of ``svtrain fit`` (benchmarks call this too, so they measure the same step).

    Args:
        image: (B, 3, H, W) linear input photos. maps: (B, 10, H, W) packed target maps (both on the model's device).
        step: 0-based index of this step (sets the scheduled learning rate).
        place: device and precision (None: float32, no autocast).
        scaler: fp16's gradient scaler (None or disabled: plain backward and step).
        configs: the loss configurations of these samples (None: drawn from ``gen`` for this batch).

    Returns:
        (loss, gradient norm before clipping) of this process's batch.
    """
    for group in opt.param_groups:
        group["lr"] = lr_at(o, step)
    with (place.autocast() if place is not None else contextlib.nullcontext()):
        pred = model(image)
    # Everything after the network is float32 (train/device.py lists the fp32 islands): the loss upcasts anyway,
    # the map terms are taken on the same float32 prediction.
    pred = pred.float()
    loss = loss_terms(pred, maps, loss_fn, gen, o, configs, step)
    opt.zero_grad(set_to_none=True)
    scaled = scaler is not None and scaler.is_enabled()
    (scaler.scale(loss) if scaled else loss).backward()
    if scaled:
        scaler.unscale_(opt)  # clip and measure the true gradients
    # clip_grad_norm_ with max_norm=inf only measures the norm (same code path, no rescale)
    norm = torch.nn.utils.clip_grad_norm_(model.parameters(), o.grad_clip if o.grad_clip > 0 else math.inf)
    if scaled:
        scaler.step(opt)  # skips the step when fp16 gradients overflowed, and lowers the scale
        scaler.update()
    else:
        opt.step()
    return float(loss.detach()), float(norm)


class Trainer:
    """One process's training: model on its device (DDP-wrapped under a data-parallel world), Adam, the loss
    generator, the precision, and the batches of its rank. ``svtrain fit`` and the benchmarks run the same loop
    (:meth:`run`), so a benchmark measures what ``fit`` does.

    Args:
        cfg: validated config.
        place: device and precision (default: from ``cfg.compute``).
        world: data-parallel world (default: a single process). The process group must already be joined.
    """

    def __init__(self, cfg: Config, place: Placement | None = None, world: World | None = None):
        self.cfg, self.world = cfg, world or World()
        self.place = place or placement(cfg.compute.device, cfg.compute.precision)
        o = cfg.optim
        net, self.opt, self.gen = build(cfg)
        if self.world.rank:  # per-rank dropout masks (rank 0 keeps the single-process stream)
            torch.manual_seed(stream_seed(o.seed, "train.rank_dropout", self.world.rank))
        self.net = net.to(self.place.device)  # in place: the optimiser's parameters move with it
        self.model: torch.nn.Module = self.net
        if self.world.size > 1:
            from torch.nn.parallel import DistributedDataParallel

            dev = self.place.device
            self.model = DistributedDataParallel(self.net, device_ids=[dev.index] if dev.type == "cuda" else None)
        self.scaler = self.place.scaler()
        self.loss_fn = make_loss(o.compile_loss)
        self.global_batch, self.batch = self.world.batches(o.batch_size, cfg.compute.global_batch)

    def loader(self, ds: PairDataset, start: int, stop: int, timeout: float = 0):
        """This rank's batches of steps start..stop-1 (CPU workers, pinned when the device is a GPU)."""
        o = self.cfg.optim
        loader = make_loader(ds, self.batch, start, stop, self.cfg.data.workers, self.global_batch, self.world.rank,
                             self.place.pin_memory, timeout)
        # A dedicated loader generator: DataLoader otherwise draws its base seed from torch's global RNG, which
        # would shift the dropout stream between an uninterrupted and a resumed run.
        loader.generator = torch.Generator().manual_seed(stream_seed(o.seed, "train.loader"))
        return loader

    def step(self, image: torch.Tensor, maps: torch.Tensor, step: int) -> tuple[float, float]:
        """One step on this rank's host batch; returns (loss of the global batch, gradient norm)."""
        # all ranks draw the global batch's configurations (same generator state everywhere) and keep their rows
        lo = self.world.rank * self.batch
        configs = sample_configs(self.global_batch, self.gen)
        configs = configs.rows(lo, lo + self.batch)
        loss, norm = train_step(self.model, self.opt, self.loss_fn, self.place.to(image), self.place.to(maps),
                                self.gen, self.cfg.optim, step, place=self.place, scaler=self.scaler, configs=configs)
        return mean_over_ranks(loss, self.world, self.place.device), norm

    def run(self, ds: PairDataset, start: int, stop: int, timeout: float = 0) -> Iterator[tuple[int, float, float]]:
        """Train steps start..stop-1 (``timeout``: seconds a loader worker may take per batch, 0 = forever).

        Yields:
            (steps done so far, loss of the global batch, gradient norm).
        """
        self.model.train()
        if stop <= start:
            return
        step = start
        for image, maps in self.loader(ds, start, stop, timeout):
            pause_hook(self.world, step)
            loss, norm = self.step(image, maps, step)
            step += 1
            yield step, loss, norm

    def state(self, step: int, losses: list[float]) -> dict:
        """Checkpoint state (a collective under a data-parallel world: every rank must call it)."""
        rngs = gather({"cpu": torch.get_rng_state(), "cuda": torch.cuda.get_rng_state(self.place.device)
                       if self.place.device.type == "cuda" else None}, self.world)
        return {"config": self.cfg.to_dict(), "model": self.net.state_dict(), "optim": self.opt.state_dict(),
                "loss_rng": self.gen.get_state(), "torch_rng": rngs[0]["cpu"], "rank_rngs": rngs,
                "scaler": self.scaler.state_dict(), "step": step, "losses": losses, "world_size": self.world.size,
                "global_batch": self.global_batch}

    def load(self, state: dict, where: Path) -> None:
        """Continue from a checkpoint state.

        Raises:
            ConfigError: another model config, or another global batch (the data order would differ).
        """
        # retired keys at their old defaults (a run from before #41) mean the same model
        if drop_retired(state["config"])["model"] != self.cfg.to_dict()["model"]:
            raise ConfigError(f"{where} holds a run with a different model config; use a new --out or --no-resume")
        g_old = int(state.get("global_batch", state["config"]["optim"]["batch_size"]))
        n_old = int(state.get("world_size", 1))
        if g_old != self.global_batch:
            raise ConfigError(f"{where} was trained with a global batch of {g_old} ({n_old} process(es)); this run's "
                              f"is {self.global_batch} ({self.world.size} x {self.batch}): pass --global-batch "
                              f"{g_old} to continue it, or --no-resume")
        self.net.load_state_dict(state["model"])
        self.opt.load_state_dict(state["optim"])
        self.gen.set_state(state["loss_rng"])
        if "scaler" in state and state["scaler"]:
            self.scaler.load_state_dict(state["scaler"])
        rngs = state.get("rank_rngs") or [{"cpu": state["torch_rng"], "cuda": None}]
        if len(rngs) == self.world.size:
            torch.set_rng_state(rngs[self.world.rank]["cpu"])
            if rngs[self.world.rank]["cuda"] is not None and self.place.device.type == "cuda":
                torch.cuda.set_rng_state(rngs[self.world.rank]["cuda"], self.place.device)
        elif self.world.main:
            log.warning("%s was trained by %d process(es), this run has %d: batches, loss configurations and weights "
                        "continue exactly, dropout masks come from fresh per-rank streams", where, n_old,
                        self.world.size)


def loss_rows(losses: list[float], every: int, partial: bool = True) -> list[tuple[int, float]]:
    """(step, mean loss of the ``every`` steps up to it) for each full block of steps, and with ``partial`` the
    last, shorter block."""
    arr = np.asarray(losses, np.float64)
    rows = [(end, float(arr[end - every:end].mean())) for end in range(every, len(arr) + 1, every)]
    if partial and len(arr) % every:
        rows.append((len(arr), float(arr[len(arr) - len(arr) % every:].mean())))
    return rows


def _row(step: int, value: float) -> str:
    return f"{step},{value:.6g}\n"


def write_loss_csv(path: Path, rows: list[tuple[int, float]]) -> None:
    """``loss.csv`` with these rows (the run's rows so far: a resumed run drops those after its checkpoint)."""
    with open(path, "w") as f:
        f.write("step,loss\n")
        f.writelines(_row(s, v) for s, v in rows)


def _write_outputs(out: Path, cfg: Config, losses: list[float], extra: dict) -> dict:
    """loss.csv, metrics.json (``extra`` holds no clock: that is timing.json's), fit_metrics.json and loss.png."""
    o = cfg.optim
    arr = np.asarray(losses, np.float64)
    rows = loss_rows(losses, o.log_every)
    write_loss_csv(out / "loss.csv", rows)
    tail = arr[-max(1, min(len(arr), 5 * o.log_every)):] if len(arr) else arr
    metrics = {"step": int(len(arr)), "loss_final": float(tail.mean()) if len(tail) else None,
               "loss_first": float(arr[:o.log_every].mean()) if len(arr) else None, **extra}
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    dvc_metrics.write(out / dvc_metrics.FIT_FILE, dvc_metrics.fit_metrics(metrics))  # what `dvc metrics` shows
    _plot(out / "loss.png", rows)
    return metrics


def _plot(path: Path, rows: list[tuple[int, float]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5), dpi=100)
    if rows:
        ax.plot([r[0] for r in rows], [r[1] for r in rows])
    ax.set_xlabel("step")
    ax.set_ylabel("loss (rendering log-L1 + map terms)")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


class CheckpointClock:
    """When ``optim.checkpoint_minutes`` have passed since the last checkpoint (0: never by time).

    Checkpointing is a collective under a data-parallel run, so every rank must decide alike: there rank 0's clock
    decides, broadcast every ``sync_every`` steps (one small collective per loss-log row, not per step).
    """

    def __init__(self, minutes: float, world: World):
        self.interval, self.world = 60.0 * float(minutes), world
        self.reset()

    def reset(self) -> None:
        self.last = time.monotonic()

    def due(self, step: int, sync_every: int) -> bool:
        if not self.interval:
            return False
        late = time.monotonic() - self.last >= self.interval
        if self.world.size <= 1:
            return late
        return step % sync_every == 0 and bool(broadcast(late, self.world))


def fit(cfg: Config, out_dir: str | Path, resume: bool | str = True, source=None, stop_after: int | None = None,
        show_progress: bool | None = None) -> dict:
    """Train (or continue training) into ``out_dir``, on ``cfg.compute``'s device and precision, as one rank of a
    data-parallel run when a launcher started this process (train/distributed.py).

    Args:
        cfg: validated config.
        out_dir: run directory (created).
        resume: continue from ``out_dir/checkpoint.pt`` when it exists, refusing (ConfigError) a checkpoint of
            other data or another config than this one but ``optim.iterations`` and machine settings
            (:func:`train.runinfo.resume_changes`); ``"if-unchanged"``: only when the checkpoint was trained from
            this config, data and code (:func:`train.runinfo.resume_key`), else start over, saying so (DVC's fit
            stage: its checkpoint persists across runs with other inputs).
        source: a data source (default: ``open_source(cfg.data)``).
        stop_after: stop after this many steps of *this call* (tests simulate an interruption),
            checkpointing first.
        show_progress: force the progress bar on/off.

    Returns:
        the metrics dict (metrics.json) with the clock and the resume step of timing.json (:data:`train.timing.KEYS`;
        on ranks other than 0 nothing is written).
    """
    cfg.check()
    checkpoint.init_weights(cfg.optim.init, cfg.model)  # a bad --init fails before the run directory exists
    o = cfg.optim
    world = world_from_env()
    place = placement(cfg.compute.device, cfg.compute.precision, world.local_rank if world.size > 1 else None)
    check_world(world.local_size, place.device)  # per machine: a cluster has more processes than one machine's GPUs
    global_batch, rank_batch = world.batches(o.batch_size, cfg.compute.global_batch)  # uneven: refused before writing
    # open the data first: a bad store must fail before the run directory exists
    src = source if source is not None else open_source(cfg.data)
    if source is None and cfg.data.store is None and world.main:
        log.warning("no data.store (--store or the params file): training on the synthetic demo source (%d "
                    "generated samples), not on rendered data", cfg.data.synthetic_samples)
    train_idx, test_idx = split_for(src, cfg.data)
    runinfo.check_run(cfg, out_dir, len(train_idx), global_batch, rank_batch, place.device, world.local_size)
    # the reader's caches: this process's share of the run's budget, before any worker copies the reader
    loader_memory.share(src, loader_memory.per_process(cfg.data, src, world.local_size))
    out = Path(out_dir)
    if world.main:
        out.mkdir(parents=True, exist_ok=True)
    if o.threads:
        torch.set_num_threads(o.threads)
    with process_group(world, place.device):
        try:
            return _fit(cfg, out, resume, src, train_idx, test_idx, stop_after, show_progress, world, place)
        except Exception as e:
            if world.size > 1 and not isinstance(e, SvgenError) and is_collective_failure(e):
                raise PeerLost(f"lost contact with the other ranks ({str(e).splitlines()[0][:120]}); "
                               f"{last_checkpoint_note(out)}") from None
            raise


def _fit(cfg: Config, out: Path, resume: bool | str, src, train_idx, test_idx, stop_after, show_progress, world: World,
         place: Placement) -> dict:
    o = cfg.optim
    ckpt_path = out / "checkpoint.pt"
    trainer = Trainer(cfg, place, world)
    start, losses = 0, []
    state = None
    prov = provenance(cfg, src)
    data = prov["data"]
    key = runinfo.resume_key(cfg, data)
    if resume and world.main and ckpt_path.exists():
        state = checkpoint.load(ckpt_path)
        if resume == "if-unchanged" and state.get("resume_key") != key:
            log.warning("%s is from a run with another config, data or code: starting over", ckpt_path)
            state = None
    state = broadcast(state, world)  # rank 0 reads, every rank continues from it (no shared file system needed)
    if state is not None:
        changed = runinfo.resume_changes(state, cfg, data)  # every rank holds the state: all refuse alike
        if changed:
            raise ConfigError(f"{ckpt_path} is a run of other data or config ({'; '.join(changed)}); pass --no-resume "
                              f"to start over there, or use another --out")
        trainer.load(state, out)
        start, losses = int(state["step"]), list(state["losses"])
        if world.main:
            log.info("resuming %s at step %d", out, start)
    resumed_from = start if state is not None else None
    if world.main:  # the checkpoint is continued or replaced: only now do the run's records change
        # the baselines' training means travel with the model: `svtrain eval` then needs no training store
        prov[MEANS_KEY] = fit_means(src, cfg.data, cfg.optim.seed)
        runinfo.record(out, cfg.data.store)
        # a params file (`svtrain fit --params` reruns it), less the machine's settings (runinfo.recorded_config)
        (out / "config.yaml").write_text(runinfo.config_text(cfg))
        (out / "provenance.json").write_text(json.dumps(prov, indent=2) + "\n")
    ds = PairDataset(src, train_idx, cfg.data.crop, o.seed, train=True, flips=cfg.data.augment,
                     centre=cfg.data.crop_at == "centre")
    stop = o.iterations if stop_after is None else min(o.iterations, start + stop_after)

    def timings(step: int, it_per_s: float | None = None) -> dict:
        """timing.json's content at ``step`` (the clock left running)."""
        wall, cpu = clock.totals()
        return {"checkpoint": {"step": step, "losses_sha256": timing.losses_digest(losses)},
                "it_per_s": it_per_s, "train_wall_s": wall, "train_cpu_s": cpu, "resumed_from": resumed_from,
                "clock_from_step": prior["clock_from_step"],
                "heldout": [{"step": s, **times[s]} for s in sorted(times)], **here}

    def save(step: int) -> None:
        st = trainer.state(step, losses)  # every rank (gathers the ranks' RNG states)
        st["config"] = runinfo.recorded_config(cfg)
        st["resume_key"], st["data"], st["provenance"] = key, data, prov
        st["heldout"] = heldout_rows  # a resumed run continues the curve (its times: timing.json)
        if world.main:
            checkpoint.save(ckpt_path, st)
            timing.write(out, timings(step))  # after the checkpoint: a timing.json always matches one

    probe = HeldoutProbe(src, test_idx, cfg.data.crop, cfg.data.eval_views, o.batch_size) \
        if o.eval_every and world.main else None
    # rows of a checkpoint from before timing.json carry their times: the curve keeps its columns only
    heldout_rows = [{k: r[k] for k in heldout.HEADER} for r in state.get("heldout", [])] if state is not None else []
    prior = timing.continued(out, start, losses, state) if state is not None and world.main else \
        {"train_wall_s": 0.0, "train_cpu_s": 0.0, "heldout": {}, "clock_from_step": start}
    clock = TrainClock(prior["train_wall_s"], prior["train_cpu_s"])
    times = dict(prior["heldout"])  # step -> the clock when the curve's row of that step was taken
    here = timing.where(cfg.data.store) if world.main else {}

    def probe_at(step: int) -> None:  # the clock is stopped around it: evaluation is not training time
        wall, cpu = clock.stop()
        if probe is not None and not any(r["step"] == step for r in heldout_rows):
            heldout_rows.append({"step": step, **probe(trainer.net, place.device)})
            times[step] = {"wall_s": wall, "cpu_s": cpu}
        clock.start()

    step = start
    probe_at(start)
    t0 = time.perf_counter()
    bar = progress(total=o.iterations, desc="fit", unit="it", initial=start, disable=(not world.main) or (
        None if show_progress is None else not show_progress), lines=True)
    loss_csv = None
    if world.main:  # appended as the run goes; a resumed run first drops the rows after its checkpoint
        write_loss_csv(out / "loss.csv", loss_rows(losses, o.log_every, partial=False))
        loss_csv = open(out / "loss.csv", "a")
    ckpt_clock = CheckpointClock(o.checkpoint_minutes, world)
    try:
        for step, loss, _ in trainer.run(ds, start, stop):
            if not math.isfinite(loss):  # the weights are now non-finite too: keep the last good checkpoint
                raise SvgenError(f"the loss became {loss} at step {step - 1}: lower optim.lr or set optim.grad_clip "
                                 f"(the last checkpoint in {out} is from before it)")
            losses.append(loss)
            bar.set_postfix(loss=f"{np.mean(losses[-o.log_every:]):.4f}", refresh=False)  # shown by the update
            bar.update(1)
            if loss_csv is not None and step % o.log_every == 0:
                loss_csv.write(_row(step, float(np.mean(losses[-o.log_every:]))))
                loss_csv.flush()  # a reader (or a killed run) sees every row written so far
            if o.eval_every and step % o.eval_every == 0:
                probe_at(step)
            if step < stop and (step % o.checkpoint_every == 0 or ckpt_clock.due(step, o.log_every)):
                save(step)
                ckpt_clock.reset()
    except KeyboardInterrupt:
        bar.close()
        if world.size == 1:  # under a data-parallel run the peers may be gone: the last periodic checkpoint stands
            save(step)
            log.info("interrupted at step %d; checkpoint saved, rerun the same command to resume", step)
        raise
    finally:
        if loss_csv is not None:
            loss_csv.close()
    bar.close()
    elapsed = time.perf_counter() - t0
    if step >= o.iterations:
        probe_at(step)  # the last point of the curve (nothing new when eval_every divides iterations)
    clock.stop()
    save(step)
    it_per_s = (step - start) / elapsed if step > start and elapsed > 0 else None
    extra = {"parameters": count_parameters(trainer.net), "train_samples": int(len(train_idx)),
             "test_samples": int(len(test_idx)), "done": step >= o.iterations,
             "device": str(place.device), "precision": place.precision, "world_size": world.size,
             "global_batch": trainer.global_batch}
    clocked = {"it_per_s": it_per_s, "train_wall_s": clock.wall, "train_cpu_s": clock.cpu,
               "resumed_from": resumed_from}  # timing.KEYS
    if not world.main:
        return {"step": step, **extra, **clocked}
    heldout.write(out / heldout.FILE, heldout_rows)
    checkpoint.save(out / "model.pt", {"config": runinfo.recorded_config(cfg), "model": trainer.net.state_dict(),
                                       "step": step, "provenance": prov})
    timing.write(out, timings(step, it_per_s))
    return {**_write_outputs(out, cfg, losses, extra), **clocked}
